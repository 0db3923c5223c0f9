"""The compiled exact checker (planning_kernel.cpp, checker 0 "mesh", collides_pairs).

It culls pairs by bounding volumes before coal's narrow phase (bounding spheres of the
inflated oriented boxes, then world boxes, then the oriented boxes) and places only the
objects that a pair still needs. Reference: Pinocchio's ``computeCollisions`` over every
collision pair with fresh data (coal's narrow phase on each pair, no broad phase, no warm
start), independent of the kernel's culling. Random configurations, points along edges,
configurations bisected to first contact and points around them, on MotionBenchMaker scenes.
"""

from __future__ import annotations

import warnings
from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON

from taskspace._native import planning_kernel
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

# scene: a valid problem (its world)
SCENES = {"bookshelf_thin": 1, "cage": 1, "table_pick": 3, "box": 3}


class Reference:
    """Exact collision test of every pair of the robot's collision model (no warm start)."""

    def __init__(self, robot: Any) -> None:
        self.model, self.geom = robot.model, robot.collision_model
        self.data, self.gdata = self.model.createData(), self.geom.createData()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            for request in self.gdata.collisionRequests:
                request.enable_cached_gjk_guess = False
                request.gjk_initial_guess = coal.GJKInitialGuess.DefaultGuess
                # EPA on GJK's "Collision" (else a deep overlap may be called free, CAGE_DEEP)
                request.enable_contact = True

    def collides(self, q: np.ndarray) -> bool:
        return bool(pin.computeCollisions(self.model, self.data, self.geom, self.gdata, q, True))

    def many(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in qs])


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _touching(ref: Reference, free: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Bisect each segment free -> colliding (reference) to 1e-7 rad: the colliding ends."""
    out = []
    for a, b in zip(free, hit):
        lo, hi = 0.0, 1.0
        while (hi - lo) * float(np.abs(b - a).max()) > 1e-7:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if ref.collides(a + mid * (b - a)) else (mid, hi)
        out.append(a + hi * (b - a))
    return np.array(out)


@pytest.mark.parametrize("scenario", list(SCENES))
def test_mesh_checker_gives_the_reference_answers(robot: Any, scenario: str) -> None:
    req = motionbenchmaker_problems(ROOT, scenario, [SCENES[scenario]])[0].apply(robot)
    kernel = CollisionChecker(robot).native_kernel()
    ref = Reference(robot)
    rng = np.random.default_rng(3)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    # random configurations, and points along edges from the start (as the planner checks)
    qs = rng.uniform(lo, hi, (300, robot.nq))
    ends = rng.uniform(lo, hi, (8, robot.nq))
    ts = np.linspace(0, 1, 30)[:, None]
    edges = np.concatenate([req.start + ts * (e - req.start) for e in ends])
    for rows in (qs, edges):
        exact = ref.many(rows)
        assert exact.any() and (~exact).any()
        np.testing.assert_array_equal(kernel.collisions(rows).astype(bool), exact)
        # one by one in a shuffled order (the last colliding pair is tested first)
        order = rng.permutation(len(rows))
        flags = [bool(kernel.first_invalid(rows[i : i + 1]) == 0) for i in order]
        np.testing.assert_array_equal(flags, exact[order])
    # at first contact (bisected to 1e-7 rad) and around it (1e-6 .. 1e-3 rad): where the
    # reference collides the kernel must too; the kernel counts a pair closer than GJK's
    # tolerance (1e-6 m) as colliding, so it may say colliding at a few free ones
    exact = ref.many(qs)
    touching = _touching(ref, qs[~exact][:12], qs[exact][:12])
    assert kernel.collisions(touching).all()
    scales = np.repeat([1e-6, 1e-5, 1e-4, 1e-3], 6)[:, None]
    near = (touching[:, None, :] + scales * rng.standard_normal((12, 24, robot.nq))).reshape(
        -1, robot.nq
    )
    near = np.clip(near, lo, hi)
    exact_near = ref.many(near)
    flags = kernel.collisions(near).astype(bool)
    assert exact_near.sum() > 40 and (~exact_near).sum() > 40
    assert not np.any(exact_near & ~flags), "mesh checker: free where the reference collides"
    assert np.mean(flags != exact_near) < 0.02
