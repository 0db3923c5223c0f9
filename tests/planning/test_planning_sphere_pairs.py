"""The double-precision re-test of the batched sphere checks tests only the filter's pairs.

For a configuration the single-precision filter (sphere_batch.hpp) cannot clear, the kernel runs
the double-precision sphere test (and coal's narrow phase for "spheres") on the collision pairs
that the filter's walk gives for that configuration, not on every pair: the pair that put it in
the filter's mask, then each later pair whose float tests pass. The answer is the double test's
only if the walk gives every pair whose spheres touch. References, independent of the kernel:

* per collision pair, the smallest clearance of its spheres recomputed here (sphere centres
  from Pinocchio's forward kinematics; analytic distances to boxes, cylinders and balls, coal's
  distance to other shapes, sphere-sphere distances for self pairs): every touching pair is
  given, exactly once; a primitive or self pair given is within twice the filter's margin of
  touching;
* Pinocchio's ``computeCollisions`` on the meshes: the "spheres" checker's answers (the narrow
  phase on the pairs given) equal it row by row, on configurations where several pairs touch.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from _mbm import ROOT, SKIP_REASON
from _sphere_reference import PairClearances, mesh_collides

from taskspace._native import planning_kernel
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

SPHERES, SPHERES_ONLY = 1, 2
OFF, CONFIRMED = 0, 1  # CollisionKernel.set_sphere_filter: double only; filter then double
PROBLEM = {"bookshelf_small": 2, "bookshelf_tall": 1, "box": 3, "cage": 1, "table_pick": 3}


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _kernel(robot: Any, scenario: str) -> tuple[Any, Any]:
    assert ROOT is not None
    motionbenchmaker_problems(ROOT, scenario, [PROBLEM[scenario]])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    kernel = space.checker.sphere_kernel()
    assert kernel.sphere_filter()
    return space, kernel


def _configurations(robot: Any, seed: int, n: int) -> np.ndarray:
    """Random configurations, and the same moved towards the middle of the joint ranges (fewer
    deep collisions: near first contact, often with one pair touching and others nearly)."""
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    rng = np.random.default_rng(seed)
    qs = rng.uniform(lo, hi, (n, robot.nq))
    mid = 0.5 * (lo + hi)
    return np.vstack([qs, mid + 0.6 * (qs - mid), mid + 0.3 * (qs - mid)])


@pytest.mark.parametrize("scenario", ["bookshelf_tall", "box", "cage", "table_pick"])
def test_the_walk_gives_every_touching_pair_once(robot: Any, scenario: str) -> None:
    """Every pair whose spheres touch (reference) is given by the walk, once; no pair is given
    twice; a primitive or self pair given is within twice the filter's margin of touching;
    nothing for the configurations the filter clears. Many configurations have several
    touching pairs (a walk that stopped after the first pair, or skipped the rest of a unit, a
    link's later obstacles or the self pairs, would miss some)."""
    space, kernel = _kernel(robot, scenario)
    ref = PairClearances(robot, space.checker.sphere_model())
    eps = kernel.sphere_filter_eps()
    qs = _configurations(robot, 21, 100)
    given = kernel.sphere_filter_pairs(qs)
    flags = kernel.sphere_filter_flags(qs).astype(bool)
    assert given.shape == (len(qs), len(robot.collision_model.collisionPairs))
    assert given.max() == 1
    np.testing.assert_array_equal(given.any(axis=1), flags)
    several = 0
    for q, row in zip(qs, given, strict=True):
        clearance = ref(q)
        touching = [k for k, c in clearance.items() if c <= 0.0]
        assert all(row[k] == 1 for k in touching), [(k, clearance[k]) for k in touching]
        tight = [k for k in np.flatnonzero(row) if k not in ref.generic]
        assert all(clearance[k] <= 2.0 * eps for k in tight)
        several += len(touching) >= 2
    assert several >= 20


@pytest.mark.parametrize("scenario", ["bookshelf_small", "box", "cage"])
def test_answers_are_the_double_tests_and_the_meshes(robot: Any, scenario: str) -> None:
    """collisions_with with the filter (the double test on the given pairs only) and without
    (every pair in double): the same answers for both sphere checkers; "spheres" (the narrow
    phase on the pairs whose spheres touch) equals Pinocchio's computeCollisions on the meshes
    row by row (the spheres cover the meshes: certified)."""
    _, kernel = _kernel(robot, scenario)
    assert kernel.certified_margin > 0.0
    collides = mesh_collides(robot)
    qs = _configurations(robot, 33, 120)
    out = {}
    for mode in (OFF, CONFIRMED):
        kernel.set_sphere_filter(mode)
        try:
            out[mode] = [kernel.collisions_with(qs, c) for c in (SPHERES, SPHERES_ONLY)]
        finally:
            kernel.set_sphere_filter(2)
    np.testing.assert_array_equal(out[CONFIRMED], out[OFF])
    mesh = np.array([collides(q) for q in qs])
    np.testing.assert_array_equal(out[CONFIRMED][0].astype(bool), mesh)
    # rows the spheres flag that the meshes find free: the narrow phase decided
    assert np.sum(out[CONFIRMED][1].astype(bool) & ~mesh) >= 10
