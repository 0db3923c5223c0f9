"""The compiled RRT-Connect's trees hold checked motions only.

Every tree edge (parent to child) was checked at its coarse points when it was added (EXTEND,
or a step of CONNECT), so every node and
every coarse point of every edge of the returned trees is free for the checker the plan used:
"spheres_only" here (conservative: free for the meshes too), or, after a fallback, "spheres"
(the meshes' answers). The reference is the kernel's own single-configuration check of those
points (``collisions_with``) and Pinocchio's broad phase (``computeCollisions``) for the
meshes, both independent of the planner's batched edge checks.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import planning_kernel, status
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

pytestmark = [
    pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}"),
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
]

DELTA = 0.03  # resolution [rad]
COARSE = 0.15  # coarse resolution [rad]: stride 5
STEP = 0.5  # EXTEND / CONNECT step [rad]
SPHERES_ONLY = 2  # the kernel's checker codes (taskspace.planning.rrt_connect.CHECKERS)
SPHERES = 1


@pytest.fixture(scope="module")
def robot():  # type: ignore[no-untyped-def]
    return motionbenchmaker_panda()


def _coarse_points(parent: np.ndarray, child: np.ndarray) -> np.ndarray:
    """The points of an edge its EXTEND or CONNECT step checks: the child and the multiples
    of the stride k * stride / n from the parent (n = ceil(|edge| / resolution))."""
    n = max(1, math.ceil(float(np.linalg.norm(child - parent)) / DELTA - 1e-12))
    stride = math.floor(COARSE / DELTA + 1e-9)
    ks = [k * stride for k in range(1, (n + stride - 1) // stride) if k * stride < n]
    ts = np.array([*ks, n], dtype=float) / n
    return parent + ts[:, None] * (child - parent)


@pytest.mark.parametrize(
    ("scenario", "index"),
    [("bookshelf_small", 1), ("table_pick", 2), ("box", 4), ("bookshelf_thin", 3), ("cage", 3)],
)
def test_tree_edges_are_free_at_their_checked_points(robot, scenario: str, index: int) -> None:  # type: ignore[no-untyped-def]
    req = motionbenchmaker_problems(ROOT, scenario, [index])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=DELTA))
    kernel = space.checker.sphere_kernel()
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    connects = 0
    for seed in range(3):
        opts = RRTConnectOptions(
            step_size=STEP,
            coarse_resolution=COARSE,
            local_sampling=0.5,
            trapped_priority=0.75,
            time_limit_s=20.0,
            seed=seed,
            checker="spheres_only",
            validator="spheres",
        )
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success
        code = SPHERES if res.log["spheres_fallback"] else SPHERES_ONLY
        for tree in res.trees:
            child = np.flatnonzero(tree.parents >= 0)
            pts = [_coarse_points(tree.nodes[tree.parents[c]], tree.nodes[c]) for c in child]
            if not pts:
                continue
            # CONNECT's steps: full steps of STEP from a node along one line
            lengths = np.linalg.norm(tree.nodes[child] - tree.nodes[tree.parents[child]], axis=1)
            connects += int(np.sum(np.isclose(lengths, STEP)))
            qs = np.vstack(pts)
            flags = kernel.collisions_with(qs, code)
            assert not flags.any(), (scenario, index, seed, qs[np.flatnonzero(flags)[:3]])
            for q in qs[:: max(1, len(qs) // 40)]:  # the meshes, by Pinocchio
                assert not pin.computeCollisions(model, data, geom, gdata, q, True)
    assert connects > 0  # full steps were added (EXTEND's and CONNECT's)
