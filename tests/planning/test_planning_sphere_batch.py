"""The single-precision sphere filter of the batched sphere checks (sphere_batch.hpp, #22 item 4).

The kernel's batched checks (edges, ``collisions_with``) run a float filter on 4 configurations
at once and the double-precision sphere test (and coal's narrow phase for "spheres") only on
the configurations it cannot clear. References, independent of the filter's code:

* the double-precision sphere test recomputed here: sphere centres from Pinocchio's forward
  kinematics, analytic distances to the obstacles' boxes and cylinders, coal's distance to the
  robot base's convex hull, sphere-sphere distances for the self pairs;
* Pinocchio's ``computeCollisions`` on the meshes (never "free" where the meshes collide);
* the kernel's double-precision path with the filter off (the path before the filter, itself
  tested against Pinocchio in test_planning_sphere_checker.py): the same answers, the same
  first colliding index of an edge, the same planned paths.

Configurations bisected to within 1e-12 of first sphere contact (penetration ~1e-12 m, far
below float's rounding of the centres, ~1e-7 m) fail without the filter's inflation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from _mbm import ROOT, SKIP_REASON
from _sphere_reference import PairClearances as SphereReference
from _sphere_reference import first_sphere_contacts, last_step_pairs, mesh_collides

from taskspace._native import planning_kernel
from taskspace.errors import InvalidInputError
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    EdgeCheckOptions,
    bisection_order,
)
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

MESH, SPHERES, SPHERES_ONLY = 0, 1, 2
# filter modes (CollisionKernel.set_sphere_filter): off (double only), filter then double on
# the lanes it cannot clear, and (default) "spheres only" trusting its sphere overlaps
OFF, CONFIRMED, TRUSTED = 0, 1, 2
PROBLEM = {"bookshelf_tall": 1, "bookshelf_thin": 1, "box": 3, "cage": 1, "table_pick": 3}


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _space(robot: Any, scenario: str) -> tuple[Any, Any, Any]:
    req = motionbenchmaker_problems(ROOT, scenario, [PROBLEM[scenario]])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    kernel = space.checker.sphere_kernel()
    assert kernel.sphere_filter()  # set up, and on by default
    assert kernel.sphere_filter_mode == TRUSTED
    return req, space, kernel


def _near_configurations(robot: Any, rng: Any, n: int) -> np.ndarray:
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    base = rng.uniform(lo, hi, (n, robot.nq))
    return np.clip(base, lo, hi)


@pytest.mark.parametrize("scenario", ["bookshelf_tall", "table_pick", "cage"])
def test_filter_against_the_double_sphere_test_and_the_meshes(robot: Any, scenario: str) -> None:
    """Random configurations and configurations around first contact: where the filter clears
    a configuration, every sphere clearance of the reference is positive and the meshes are
    free; where it flags one, some clearance is within twice its stated margin (or the sphere
    is near the base hull's box, which the filter tests instead of the hull)."""
    _, space, kernel = _space(robot, scenario)
    ref = SphereReference(robot, space.checker.sphere_model())
    mesh = mesh_collides(robot)
    eps = kernel.sphere_filter_eps()
    assert 1e-6 < eps < 1e-3
    rng = np.random.default_rng(3)
    qs = _near_configurations(robot, rng, 160)
    contacts = first_sphere_contacts(kernel, qs, rng, 12)
    shifted = (
        contacts + rng.standard_normal(contacts.shape) * np.repeat([1e-6, 1e-5, 1e-4], 4)[:, None]
    )
    allq = np.vstack([qs, contacts, shifted])
    flags = kernel.sphere_filter_flags(allq).astype(bool)
    both = 0
    for q, flag in zip(allq, flags, strict=True):
        prim, other = ref.clearance(q)
        if not flag:
            assert prim > 0.0 and other > 0.0, (prim, other)
            assert not mesh(q)
        elif prim > 2.0 * eps:
            assert other < 0.15, (prim, other)  # the hull's box, not the hull
        both += bool(flag)
    assert 0 < both < len(allq)


@pytest.mark.parametrize("scenario", ["box", "cage"])
def test_first_contacts_are_never_cleared(robot: Any, scenario: str) -> None:
    """Configurations whose spheres overlap by about 1e-12 m (double precision): the filter
    flags every one (float's rounding alone, about 1e-7 m, would clear about half)."""
    _, space, kernel = _space(robot, scenario)
    ref = SphereReference(robot, space.checker.sphere_model())
    rng = np.random.default_rng(5)
    qs = _near_configurations(robot, rng, 120)
    contacts = first_sphere_contacts(kernel, qs, rng, 40)
    prim = np.array([ref.clearance(q) for q in contacts])
    depth = prim.min(axis=1)
    # at contact (both tests agree): the kernel counts a sphere within GJK's tolerance (1e-6 m)
    # of the base hull as touching it; the others touch a box, cylinder or sphere
    assert np.all(depth <= 1e-6 + 1e-9) and np.all(depth > -1e-6)
    assert np.sum(np.abs(prim[:, 0]) < 1e-9) >= 30
    assert kernel.sphere_filter_flags(contacts).all()
    assert kernel.collisions_with(contacts, SPHERES_ONLY).all()


@pytest.mark.parametrize("scenario", ["bookshelf_tall", "box", "table_pick"])
def test_filter_on_gives_the_double_path_answers(robot: Any, scenario: str) -> None:
    """collisions_with and first_invalid_on_edge (the first colliding index in bisection order,
    early exit) with the filter: the double path's answers for "spheres" (also the first index
    that Pinocchio's meshes find colliding), for collisions_with and, confirmed, for edges;
    trusted, an edge's "spheres only" index differs only where it is colliding within twice
    the filter's margin of touching (an earlier index in bisection order)."""
    _, space, kernel = _space(robot, scenario)
    mesh = mesh_collides(robot)
    ref = SphereReference(robot, space.checker.sphere_model())
    eps = kernel.sphere_filter_eps()
    rng = np.random.default_rng(8)
    qs = _near_configurations(robot, rng, 300)
    contacts = first_sphere_contacts(kernel, qs, rng, 20)
    allq = np.vstack([qs, contacts])
    flags = {}
    for mode in (OFF, CONFIRMED, TRUSTED):
        kernel.set_sphere_filter(mode)
        flags[mode] = [kernel.collisions_with(allq, c) for c in (SPHERES, SPHERES_ONLY)]
    np.testing.assert_array_equal(flags[CONFIRMED], flags[OFF])
    np.testing.assert_array_equal(flags[TRUSTED], flags[OFF])  # queries: the double answers
    n = 13
    order = bisection_order(n)
    found = 0
    for k in range(30):
        a = qs[k]
        b = a + rng.standard_normal(robot.nq) * 0.4
        got = {}
        for mode in (OFF, CONFIRMED, TRUSTED):
            kernel.set_sphere_filter(mode)
            got[mode] = [kernel.first_invalid_on_edge(a, b, n, c) for c in (SPHERES, SPHERES_ONLY)]
        assert got[CONFIRMED] == got[OFF]
        assert got[TRUSTED][0] == got[OFF][0]
        if got[TRUSTED][1] != got[OFF][1]:  # an earlier index, within the margin
            j = got[TRUSTED][1]
            assert got[OFF][1] == -1 or order.index(j) < order.index(got[OFF][1])
            assert ref.clearance(a + j / n * (b - a))[0] <= 2.0 * eps
        expect = next((j for j in order if mesh(a + j / n * (b - a))), -1)
        assert got[TRUSTED][0] == expect
        found += expect >= 0
    assert 0 < found < 30


def test_planner_paths_equal_with_and_without_the_filter(robot: Any) -> None:
    """The planner with the filter: the same paths and check counts as without where the answers
    are the same ("spheres"; "spheres only" confirmed), with fewer double-precision sphere tests
    (the filter is used); trusted, "spheres only" plans paths that the meshes find free."""
    for scenario in ("bookshelf_tall", "table_pick"):
        req, space, kernel = _space(robot, scenario)
        mesh = mesh_collides(robot)  # with this scene's obstacles (not the previous test's)
        for checker, mode in (("spheres", TRUSTED), ("spheres_only", CONFIRMED)):
            out = {}
            for m in (OFF, mode):
                kernel.set_sphere_filter(m)
                kernel.reset_sphere_stats()
                opts = RRTConnectOptions(seed=2, checker=checker, validator="spheres")
                res = rrt_connect(space, req.start, req.goal, opts)
                assert res.success
                out[m] = (np.array(res.path), res.collision_checks, sum(kernel.sphere_stats()))
            np.testing.assert_array_equal(out[mode][0], out[OFF][0])
            assert out[mode][1] == out[OFF][1]
            assert out[mode][2] < out[OFF][2]
        kernel.set_sphere_filter(TRUSTED)
        opts = RRTConnectOptions(seed=3, checker="spheres_only", validator="spheres")
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success
        for a, b in zip(res.path[:-1], res.path[1:], strict=True):
            n = max(1, int(np.ceil(np.abs(b - a).max() / 0.01)))
            assert not any(mesh(a + t * (b - a)) for t in np.linspace(0.0, 1.0, n + 1))


@pytest.mark.parametrize("scenario", ["table_pick", "bookshelf_thin"])
def test_simd_levels_agree(robot: Any, scenario: str) -> None:
    """The batched checks at every SIMD level of this processor (set_simd: 1 SSE2, 2 AVX2 with
    FMA, 3 AVX-512; TASKSPACE_SIMD lowers the initial one) give the same answers, bit for bit:
    on configurations bisected to the last representable step before sphere contact (a
    rounding difference in the double placements would flip some), on random ones and on
    edges, with and without the filter (13 and 22 obstacles). The filter's builds round
    differently (FMA from level 2 on): their masks may differ, but each holds every
    configuration the double test finds colliding."""
    _, _, kernel = _space(robot, scenario)
    initial = kernel.simd
    levels = list(range(1, type(kernel).max_simd + 1))
    rng = np.random.default_rng(12)
    qs = _near_configurations(robot, rng, 200)
    kernel.set_sphere_filter(OFF)
    flags = kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)
    free, hit = qs[~flags], qs[flags]
    allq = np.vstack([qs, last_step_pairs(kernel, free, hit, 20)])
    out = {}
    masks = {}
    try:
        for level in levels:
            kernel.set_simd(level)
            assert kernel.simd == level
            row = []
            for mode in (OFF, TRUSTED):
                kernel.set_sphere_filter(mode)
                row += [kernel.collisions_with(allq, c) for c in (SPHERES, SPHERES_ONLY)]
                edges = [kernel.first_invalid_on_edge(qs[k], qs[k + 1], 15, 2) for k in range(40)]
                row.append(edges)
            out[level] = row
            masks[level] = kernel.sphere_filter_flags(allq).astype(bool)
    finally:
        kernel.set_simd(initial)
        kernel.set_sphere_filter(TRUSTED)
    for level in levels:
        for x, y in zip(out[1], out[level], strict=True):
            np.testing.assert_array_equal(x, y)
        colliding = out[1][1].astype(bool)  # the double test, filter off
        assert np.all(masks[level][colliding])
    boundary = out[1][1][len(qs) :]  # the double test at the two sides of each contact
    assert boundary[0::2].sum() == 0 and boundary[1::2].all()
    with pytest.raises(InvalidInputError, match="simd level"):
        kernel.set_simd(4)


def test_fine_pass_checks_the_pending_edges_as_one_list(robot: Any) -> None:
    """The fine pass checks the fine points of all pending edges of a candidate path as one
    list (fuller batches); the first colliding point decides which edges are cleared and which
    one is removed with its subtree, as when checking edge after edge. Against Pinocchio: every
    returned path is free for the meshes at every point of the full resolution, its nodes and
    coarse points clear for the double sphere test recomputed here, and no exact re-check
    failed; the plans include lazy rejections (fine-pass collisions), so that an edge wrongly
    cleared or kept would show."""
    stride = 5  # coarse_resolution 0.15 / resolution 0.03
    rejections = 0
    assert ROOT is not None
    # problems and seeds whose plans have lazy rejections (1 and 3)
    for scenario, index, seed in (("box", 6, 2), ("bookshelf_thin", 8, 0)):
        req = motionbenchmaker_problems(ROOT, scenario, [index])[0].apply(robot)
        space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
        checker: Any = space.checker
        reference = SphereReference(robot, checker.sphere_model())
        mesh = mesh_collides(robot)  # with this scene's obstacles
        opts = RRTConnectOptions(
            seed=seed, checker="spheres_only", validator="spheres", fallback_iterations=None
        )
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success
        assert res.log["sphere_recheck_failed"] == 0.0
        rejections += int(res.log["lazy_rejections"])
        last = len(res.path) - 2
        for e, (a, b) in enumerate(zip(res.path[:-1], res.path[1:], strict=True)):
            n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.03 - 1e-12)))
            # the coarse points: multiples of the stride from the tree's parent, which is
            # either end of the path's edge (a goal-tree edge runs backwards)
            coarse = np.arange(n + 1) % stride == 0
            coarse[-1] = True
            clear = np.ones(n + 1, dtype=bool)
            for k in range(n + 1):
                q = a + (k / n) * (b - a)
                assert not mesh(q)
                # start and goal: checked on the meshes only (they may be nearer than the
                # spheres' margin to an obstacle)
                end = (e == 0 and k == 0) or (e == last and k == n)
                if (coarse[k] or coarse[n - k]) and not end:
                    clear[k] = min(reference.clearance(q)) > 0.0
            assert clear[coarse].all() or clear[coarse[::-1]].all(), (scenario, e, n)
    assert rejections > 0
