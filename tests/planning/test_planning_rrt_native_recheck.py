"""Every point at the resolution of a compiled RRT-Connect path with a sphere checker is free.

Reference: Pinocchio's broad-phase pool on the meshes (``CollisionChecker`` without the
kernel), at the points ``k / n`` of every returned edge. Two sphere models: the robot's,
with its volume certificate (the default: no exact re-check), and the same spheres shrunk
a thousandfold without a certificate (they see almost nothing, so the exact checker, through
the lazy fine pass and the re-check of the returned path, is the only guard).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace._native import planning_kernel, status
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

pytestmark = [
    pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}"),
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
]

POOL = CollisionCheckerOptions(native=False)  # Pinocchio's broad-phase pool, no kernel


@pytest.fixture(scope="module")
def robot():  # type: ignore[no-untyped-def]
    return motionbenchmaker_panda()


def _edge_points(path: np.ndarray, resolution: float) -> np.ndarray:
    """Points k / n of every edge, n = ceil(|edge| / resolution) (end points included)."""
    out = []
    for a, b in zip(path[:-1], path[1:]):  # noqa: RUF007
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / resolution - 1e-12))
        out.append(a + (np.arange(n + 1) / n)[:, None] * (b - a))
    return np.vstack(out)


@pytest.mark.parametrize(
    ("scenario", "index"),
    [("bookshelf_small", 2), ("box", 3), ("cage", 3), ("table_pick", 6), ("table_under_pick", 8)],
)
def test_certified_sphere_paths_are_free(robot, scenario: str, index: int) -> None:  # type: ignore[no-untyped-def]
    req = motionbenchmaker_problems(ROOT, scenario, [index])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    assert space.checker.sphere_kernel().certified_margin > 0.0
    reference = CollisionChecker(robot, POOL)
    for seed in range(2):
        opts = RRTConnectOptions(
            seed=seed, time_limit_s=2.0, checker="spheres_only", validator="spheres"
        )
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success and res.log["exact_recheck_checks"] == 0.0
        assert reference.are_valid(_edge_points(res.path, 0.03)).all()
        # finer, a path may graze an obstacle between two checked points, only there
        assert reference.are_valid(_edge_points(res.path, 0.01)).mean() > 0.97


def test_uncertified_spheres_recheck_the_goal_trees_coarse_points(robot) -> None:  # type: ignore[no-untyped-def]
    # resolution 0.1, coarse 0.5, steps of 1.7: 17 segments, stride 5. The goal tree's edges
    # run child to parent along the path; their coarse points (multiples of 5 from the parent)
    # were re-checked from the child (12, 7, 2), so an obstacle only at them was missed
    # (found on table_pick 1, seed 101).
    req = motionbenchmaker_problems(ROOT, "table_pick", [1])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.1))
    kernel = space.checker.native_kernel()
    spheres = space.checker.sphere_model()
    kernel.set_spheres(
        spheres.centers,
        spheres.radii * 1e-3,
        spheres.joints.astype(np.int32),
        spheres.geometries.astype(np.int32),
        0.0,
    )
    assert space.checker.sphere_kernel().certified_margin == 0.0
    reference = CollisionChecker(robot, POOL)
    for seed in (101, 1, 2):
        opts = RRTConnectOptions(
            step_size=1.7,
            coarse_resolution=0.5,
            seed=seed,
            time_limit_s=2.0,
            checker="spheres_only",
            validator="mesh",
            fallback_iterations=None,
        )
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success
        assert reference.are_valid(_edge_points(res.path, 0.1)).all(), seed
