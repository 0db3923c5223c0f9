"""The compiled sphere checker (planning_kernel.cpp, checkers 1 and 2) and RRT-Connect with it.

Reference: Pinocchio's ``computeCollisions`` over every collision pair (coal's exact narrow
phase on each pair, no broad phase, no spheres, GJK warm start off), independent of the
kernel's culling. Checker 2 (spheres only) must never call "free" a configuration the
reference finds colliding; checker 1 (spheres, then the exact narrow phase where they touch)
must give the reference's answers. Random configurations, configurations bisected to first
contact, edges, and planned paths (densely) on the MotionBenchMaker Panda scenes.
"""

from __future__ import annotations

import itertools
import warnings
from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON

from taskspace._native import planning_kernel
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    EdgeCheckOptions,
    bisection_order,
)
from taskspace.planning.rrt_connect import VALIDATORS, RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

MESH, SPHERES, SPHERES_ONLY = 0, 1, 2
# A valid problem (start and goal free) per scenario.
PROBLEM = {s: 1 for s in MOTIONBENCHMAKER_SCENARIOS} | {"box": 3, "table_pick": 3}


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
                # EPA on GJK's "Collision": without it coal compares GJK's last distance (up
                # to 1e-6) with a 1e-12 threshold and may call a deep overlap free (CAGE_DEEP)
                request.enable_contact = True

    def collides(self, q: np.ndarray) -> bool:
        return bool(pin.computeCollisions(self.model, self.data, self.geom, self.gdata, q, True))

    def many(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in qs])


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _scene(robot: Any, scenario: str) -> tuple[Any, Any]:
    req = motionbenchmaker_problems(ROOT, scenario, [PROBLEM[scenario]])[0].apply(robot)
    kernel = CollisionChecker(robot).sphere_kernel()
    assert kernel.has_spheres and kernel.sphere_count > 100
    return req, kernel


def _touching(ref: Reference, free: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Bisect each segment free -> colliding (reference) to 1e-6 rad: the colliding ends."""
    out = []
    for a, b in zip(free, hit):
        lo, hi = 0.0, 1.0
        while (hi - lo) * float(np.abs(b - a).max()) > 1e-6:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if ref.collides(a + mid * (b - a)) else (mid, hi)
        out.append(a + hi * (b - a))
    return np.array(out)


@pytest.mark.parametrize("scenario", MOTIONBENCHMAKER_SCENARIOS)
def test_spheres_never_free_where_the_meshes_collide(robot: Any, scenario: str) -> None:
    _, kernel = _scene(robot, scenario)
    ref = Reference(robot)
    rng = np.random.default_rng(7)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (600, robot.nq))
    exact = ref.many(qs)
    assert exact.any() and (~exact).any()
    only = kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)
    spheres = kernel.collisions_with(qs, SPHERES).astype(bool)
    assert not np.any(exact & ~only), "spheres only: free where the meshes collide"
    np.testing.assert_array_equal(spheres, exact)  # spheres, then exact: the same answers
    # conservativeness: colliding for the spheres, free for the meshes (reported; sane bound)
    false_hits = float(np.mean(only[~exact]))
    print(f"{scenario}: spheres only flag {false_hits:.1%} of the free configurations")
    assert false_hits < 0.5
    # configurations at first contact (bisected to 1e-6 rad), in a shuffled order
    touching = _touching(ref, qs[~exact][:15], qs[exact][:15])
    assert ref.many(touching).all()
    for checker in (SPHERES_ONLY, SPHERES, MESH):
        assert kernel.collisions_with(touching, checker).all(), checker
    mixed = np.vstack([touching, qs[:40]])[rng.permutation(len(touching) + 40)]
    np.testing.assert_array_equal(kernel.collisions_with(mixed, SPHERES), ref.many(mixed))


@pytest.mark.parametrize("scenario", ["cage", "bookshelf_tall", "table_pick"])
def test_certified_spheres_near_contact(robot: Any, scenario: str) -> None:
    """The volume certificate that lets the planner skip the exact re-check: where "spheres
    only" says free, the reference says free, on configurations around first contact
    (random offsets of 1e-5 to 1e-2 rad from configurations bisected to contact, both
    sides)."""
    _, kernel = _scene(robot, scenario)
    assert kernel.certified_margin > 0.0
    ref = Reference(robot)
    rng = np.random.default_rng(11)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (300, robot.nq))
    exact = ref.many(qs)
    touching = _touching(ref, qs[~exact][:20], qs[exact][:20])
    scales = np.repeat([1e-5, 1e-4, 1e-3, 1e-2], 10)[:, None]
    near = (touching[:, None, :] + scales * rng.standard_normal((20, 40, robot.nq))).reshape(
        -1, robot.nq
    )
    near = np.clip(near, lo, hi)
    exact_near = ref.many(near)
    only = kernel.collisions_with(near, SPHERES_ONLY).astype(bool)
    assert not np.any(exact_near & ~only), "spheres only: free where the meshes collide"
    # "spheres" never free where the reference collides; at a few configurations within
    # 1e-4 rad of contact it says colliding where the reference says free (coal's narrow
    # phase at placements that differ by rounding, inside GJK's tolerance): conservative
    sph = kernel.collisions_with(near, SPHERES).astype(bool)
    assert not np.any(exact_near & ~sph), "spheres: free where the meshes collide"
    assert np.mean(sph != exact_near) < 0.01
    # both sides of the contact are sampled, and some free ones are certified by the spheres
    assert exact_near.sum() > 100 and (~exact_near).sum() > 100
    assert (~only).sum() > 0


# cage: panda_hand_0 (a Convex) 3.5 cm inside side_right (a Box), reported free by coal's
# collide without contact information (Pinocchio's default requests, coal 3.0.3).
CAGE_DEEP = [
    -1.439221205408515,
    0.8387561294300804,
    2.5069599626644887,
    -2.1441663789806995,
    1.6692096036421296,
    2.974228469191759,
    2.0465730883600104,
]


def test_a_deep_overlap_is_a_collision(robot: Any) -> None:
    """GJK stops with "Collision" at a last distance of 1.9e-7 m; coal without contact
    information compares it with a 1e-12 threshold and reports the pair free. The kernel's
    checkers set the threshold to GJK's tolerance: colliding, as the LP and coal with EPA."""
    _, kernel = _scene(robot, "cage")
    model, geom = robot.model, robot.collision_model
    q = np.array(CAGE_DEEP)
    names = [o.name for o in geom.geometryObjects]
    a, b = names.index("panda_hand_0"), names.index("side_right")
    data, gdata = model.createData(), geom.createData()
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    hand, box = geom.geometryObjects[a].geometry, geom.geometryObjects[b].geometry
    pts = np.array(hand.points()) @ gdata.oMg[a].rotation.T + gdata.oMg[a].translation
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    corners = (signs * (box.halfSide - 0.03)) @ gdata.oMg[b].rotation.T + gdata.oMg[b].translation
    assert _overlap_lp(pts, corners)  # overlap even with the box 3 cm thinner on every side
    tf = [coal.Transform3s(gdata.oMg[i].rotation, gdata.oMg[i].translation) for i in (a, b)]
    request = coal.CollisionRequest()
    request.enable_contact = True
    assert coal.collide(hand, tf[0], box, tf[1], request, coal.CollisionResult()) > 0
    assert Reference(robot).collides(q)
    for checker in (MESH, SPHERES, SPHERES_ONLY):
        assert kernel.collisions_with(q[None], checker)[0] == 1, checker
    # the Python-side queries (taskspace.model.collision_requests: enable_contact)
    assert not robot.is_collision_free(q)
    assert ("panda_hand_0", "side_right") in robot.colliding_pairs(q)
    for broadphase in (True, False):
        options = CollisionCheckerOptions(native=False, broadphase=broadphase)
        assert not CollisionChecker(robot, options).is_valid(q), broadphase


# Issue #22: cage, panda_link6_0 (a Convex) 19 um inside side_frontA (a Box).
CAGE_TOUCH = [
    -1.091186280603318,
    -1.4945921400045976,
    1.5068656607896722,
    -2.6320670346076724,
    -2.074216949726308,
    0.5273839303570043,
    -2.4068469292402144,
]


def _overlap_lp(points: np.ndarray, corners: np.ndarray) -> bool:
    """Do the convex hulls of two point sets intersect? (a common convex combination, LP)"""
    from scipy.optimize import linprog

    n, m = len(points), len(corners)
    a_eq = np.zeros((5, n + m))
    a_eq[:3, :n], a_eq[:3, n:] = points.T, -corners.T
    a_eq[3, :n] = a_eq[4, n:] = 1.0
    b_eq = np.array([0.0, 0.0, 0.0, 1.0, 1.0])
    return linprog(np.zeros(n + m), A_eq=a_eq, b_eq=b_eq, bounds=(0, None)).status == 0


def test_spheres_agree_with_the_meshes_through_a_touching_configuration(robot: Any) -> None:
    """Issue #22: at CAGE_TOUCH and along lines through it (13 points per joint, +-3e-4 rad),
    "spheres" (and the mesh checker) give Pinocchio's answers on fresh data; the penetration
    of the pair is confirmed by an LP on the link's vertices and the box's corners.

    The cause was the link's Convex (buildConvexRepresentation: the mesh's triangles as faces):
    coal's hill-climbing support stopped short, and GJK/EPA reported the link 47 um away from
    the box after a 2e-16 change of its placement (the spheres path places it from its own
    kinematics); the answers along these lines were noisy for every checker.
    """
    _, kernel = _scene(robot, "cage")
    ref = Reference(robot)
    model, geom = robot.model, robot.collision_model
    q = np.array(CAGE_TOUCH)
    names = [o.name for o in geom.geometryObjects]
    a, b = names.index("panda_link6_0"), names.index("side_frontA")
    pair = next(k for k, p in enumerate(geom.collisionPairs) if {p.first, p.second} == {a, b})
    data, gdata = model.createData(), geom.createData()
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    assert pin.computeCollision(geom, gdata, pair)
    link, box = geom.geometryObjects[a].geometry, geom.geometryObjects[b].geometry
    pts = np.array(link.points()) @ gdata.oMg[a].rotation.T + gdata.oMg[a].translation
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    for shrink, inside in ((0.0, True), (1e-5, True), (5e-5, False)):
        corners = (signs * (box.halfSide - shrink)) @ gdata.oMg[b].rotation.T
        assert _overlap_lp(pts, corners + gdata.oMg[b].translation) == inside, shrink
    ts = np.linspace(-3e-4, 3e-4, 13)
    for j in range(robot.nq):
        qs = q + np.outer(ts, np.eye(robot.nq)[j])
        exact = ref.many(qs).astype(int)
        for checker in (MESH, SPHERES):
            np.testing.assert_array_equal(
                kernel.collisions_with(qs, checker), exact, f"{j} {checker}"
            )
        assert not np.any(exact & (1 - kernel.collisions_with(qs, SPHERES_ONLY)))


def test_no_stale_warm_start(robot: Any) -> None:
    """Why the kernel turns Pinocchio's GJK warm start off, and its answers without it.

    bookshelf_small problem 1: panda_link5 is 1.3 cm inside shelf_bottom at configuration b;
    with the GJK guess Pinocchio's requests cache from a call of the same pair at
    configuration a, coal's narrow phase reports the pair free. The kernels call a pair's
    narrow phase only at some configurations (when its boxes or spheres touch), so the cached
    guess may come from far away (with it kept, the sphere checker's answers differed from
    the reference in test_spheres_never_free_where_the_meshes_collide).
    """
    motionbenchmaker_problems(ROOT, "bookshelf_small", [1])[0].apply(robot)
    rng = np.random.default_rng(0)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (1000, robot.nq))
    a, b = qs[192], qs[837]
    model, geom = robot.model, robot.collision_model
    pair = next(
        p
        for p, cp in enumerate(geom.collisionPairs)
        if {geom.geometryObjects[cp.first].name, geom.geometryObjects[cp.second].name}
        == {"panda_link5_0", "shelf_bottom"}
    )
    data, gdata = model.createData(), geom.createData()  # Pinocchio's default requests
    pin.updateGeometryPlacements(model, data, geom, gdata, a)
    pin.computeCollision(geom, gdata, pair)
    pin.updateGeometryPlacements(model, data, geom, gdata, b)
    cp = geom.collisionPairs[pair]
    result = coal.DistanceResult()
    coal.distance(
        geom.geometryObjects[cp.first].geometry,
        gdata.oMg[cp.first],
        geom.geometryObjects[cp.second].geometry,
        gdata.oMg[cp.second],
        coal.DistanceRequest(),
        result,
    )
    assert result.min_distance < -0.01  # 1.3 cm deep ...
    assert not pin.computeCollision(geom, gdata, pair)  # ... and "free" after the call at a
    kernel = CollisionChecker(robot).sphere_kernel()
    assert Reference(robot).collides(b)
    for checker in (SPHERES, MESH, SPHERES_ONLY):
        assert kernel.collisions_with(np.stack([a, b, b]), checker)[1:].all(), checker
        assert kernel.collisions_with(qs[:838], checker)[-1] == 1, checker


def test_edge_in_one_call_matches_the_reference_order(robot: Any) -> None:
    _, kernel = _scene(robot, "bookshelf_tall")
    ref = Reference(robot)
    rng = np.random.default_rng(3)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    seen = {True: 0, False: 0}
    for _ in range(60):
        q0 = rng.uniform(lo, hi)
        q1 = np.clip(q0 + rng.normal(0.0, 0.6, robot.nq), lo, hi)
        n = int(rng.integers(1, 40))
        order = bisection_order(n)
        flags = [ref.collides(q0 + (k / n) * (q1 - q0)) for k in order]
        want = int(order[flags.index(True)]) if any(flags) else -1
        got = kernel.first_invalid_on_edge(q0, q1, n, SPHERES)
        assert got == want
        assert kernel.first_invalid_on_edge(q0, q1, n, MESH) == want
        only = kernel.first_invalid_on_edge(q0, q1, n, SPHERES_ONLY)
        if want >= 0:  # the conservative check stops at or before the first collision
            assert only >= 0 and list(order).index(only) <= list(order).index(want)
        seen[want >= 0] += 1
    assert seen[True] > 5 and seen[False] > 5


def _dense_valid(ref: Reference, path: np.ndarray, step: float) -> bool:
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        for t in np.linspace(0.0, 1.0, n + 1):
            if ref.collides(a + t * (b - a)):
                return False
    return True


@pytest.mark.parametrize("scenario", ["bookshelf_small", "box", "table_under_pick"])
def test_paths_planned_with_spheres_are_exact_valid(robot: Any, scenario: str) -> None:
    req, _ = _scene(robot, scenario)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    ref = Reference(robot)
    for seed in range(2):
        mesh = rrt_connect(space, req.start, req.goal, RRTConnectOptions(seed=seed))
        spheres = rrt_connect(
            space, req.start, req.goal, RRTConnectOptions(seed=seed, checker="spheres")
        )
        assert spheres.success and spheres.log["checker"] == 1.0
        # the certified spheres (sphere_model's volume certificate): no re-check
        assert spheres.log["exact_recheck_checks"] == 0.0
        assert spheres.log["sphere_recheck_failed"] == 0.0
        # the same answers as the exact checker: the same tree and path
        np.testing.assert_array_equal(spheres.path, mesh.path)
        assert _dense_valid(ref, spheres.path, 0.03)
        # the "spheres" validator (fine pass and re-check, batched): the same answers, the
        # same lazy rejections, hence the same path
        validated = rrt_connect(
            space,
            req.start,
            req.goal,
            RRTConnectOptions(seed=seed, checker="spheres", validator="spheres"),
        )
        assert validated.log["validator"] == 1.0
        assert validated.log["exact_recheck_checks"] == 0.0
        np.testing.assert_array_equal(validated.path, mesh.path)
        for validator in VALIDATORS:
            only = rrt_connect(
                space,
                req.start,
                req.goal,
                RRTConnectOptions(seed=seed, checker="spheres_only", validator=validator),
            )
            if only.success:
                assert np.array_equal(only.path[0], req.start)
                assert np.array_equal(only.path[-1], req.goal)
                # valid at the space's resolution, as the exact checker's paths (between
                # those points only certify=True proves it: the spheres' own bulge is no
                # margin to count on, and tighter spheres leave less of it)
                assert _dense_valid(ref, only.path, 0.03)
        certified = rrt_connect(
            space,
            req.start,
            req.goal,
            RRTConnectOptions(seed=seed, checker="spheres", certify=True),
        )
        if certified.success:  # proven free between its points: densely valid
            assert _dense_valid(ref, certified.path, 0.01)


def test_uncertified_spheres_are_rechecked_exactly(robot: Any) -> None:
    """Spheres set without the volume certificate (certified_margin 0): the returned path is
    re-checked with the exact checker; with it, not (its sphere answers imply the exact's)."""
    req, _ = _scene(robot, "box")
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    goal = req.start + 0.1 * (req.goal - req.start) / np.linalg.norm(req.goal - req.start)
    ref = Reference(robot)
    assert ref.collides(goal) is False
    spheres = space.checker.sphere_model()
    assert space.checker.sphere_kernel().certified_margin == spheres.certified_margin > 0.0
    args = (
        spheres.centers,
        spheres.radii,
        spheres.joints.astype(np.int32),
        spheres.geometries.astype(np.int32),
    )
    try:
        space.checker.sphere_kernel().set_spheres(*args)  # no certificate
        for checker in ("spheres", "spheres_only"):
            res = rrt_connect(space, req.start, goal, RRTConnectOptions(checker=checker))
            assert res.success and len(res.path) == 2  # the straight line
            # both ends and the 3 interior points at 0.03 rad, with the exact checker
            assert res.log["exact_recheck_checks"] == 5.0
            res = rrt_connect(space, req.start, req.goal, RRTConnectOptions(checker=checker))
            assert res.success and res.log["exact_recheck_checks"] >= len(res.path)
    finally:
        space.checker.sphere_kernel().set_spheres(*args, spheres.certified_margin)
    for checker in ("spheres", "spheres_only"):
        res = rrt_connect(space, req.start, req.goal, RRTConnectOptions(checker=checker))
        assert res.success and res.log["exact_recheck_checks"] == 0.0
        assert _dense_valid(ref, res.path, 0.01)


def test_bad_inputs(robot: Any) -> None:
    motionbenchmaker_problems(ROOT, "box", [3])[0].apply(robot)
    checker = CollisionChecker(robot)
    kernel = checker.native_kernel()
    q = np.zeros((1, robot.nq))
    with pytest.raises(InvalidInputError, match="set_spheres first"):
        kernel.collisions_with(q, SPHERES)
    with pytest.raises(InvalidInputError, match="checker must be"):
        kernel.collisions_with(q, 3)
    spheres = checker.sphere_model()
    keep = spheres.geometries != spheres.geometries[0]
    with pytest.raises(InvalidInputError, match="without spheres: panda_link1_0"):
        kernel.set_spheres(
            spheres.centers[keep],
            spheres.radii[keep],
            spheres.joints[keep].astype(np.int32),
            spheres.geometries[keep].astype(np.int32),
        )
    with pytest.raises(InvalidInputError, match="attached to joint"):
        kernel.set_spheres(
            spheres.centers,
            spheres.radii,
            (spheres.joints + 1).astype(np.int32),
            spheres.geometries.astype(np.int32),
        )
    with pytest.raises(InvalidInputError, match="M rows"):
        kernel.set_spheres(
            spheres.centers[:3],
            spheres.radii,
            spheres.joints.astype(np.int32),
            spheres.geometries.astype(np.int32),
        )
    space = ConfigurationSpace.from_robot(robot)
    with pytest.raises(UnknownNameError, match="valid checkers are: clearance, mesh, spheres"):
        rrt_connect(space, q[0], q[0], RRTConnectOptions(checker="sphere"))
    with pytest.raises(UnknownNameError, match="valid validators are: mesh, spheres"):
        rrt_connect(space, q[0], q[0], RRTConnectOptions(validator="exact"))


def test_spheres_only_falls_back_to_spheres(robot: Any) -> None:
    """Where the conservative spheres close the passage, the plan goes on with "spheres"."""
    req, _ = _scene(robot, "table_pick")
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    budget = {"seed": 0, "max_iterations": 1500, "time_limit_s": None}
    only = RRTConnectOptions(checker="spheres_only", fallback_iterations=None, **budget)
    stuck = rrt_connect(space, req.start, req.goal, only)
    assert not stuck.success  # the spheres' margin closes the grasp (this problem, seed)
    assert stuck.log["spheres_fallback"] == 0.0
    assert stuck.log["spheres_fallback_iteration"] == -1.0
    assert RRTConnectOptions().fallback_iterations == 200
    fell = rrt_connect(
        space, req.start, req.goal, RRTConnectOptions(checker="spheres_only", **budget)
    )
    assert fell.success and fell.log["spheres_fallback"] == 1.0
    assert fell.log["spheres_fallback_iteration"] == 201.0  # visible in the result
    assert fell.iterations > 201
    assert _dense_valid(Reference(robot), fell.path, 0.03)
    # from the first iteration: the "spheres" plan, i.e. the exact checker's trees and path
    first = RRTConnectOptions(checker="spheres_only", fallback_iterations=0, **budget)
    at_once = rrt_connect(space, req.start, req.goal, first)
    mesh = rrt_connect(space, req.start, req.goal, RRTConnectOptions(**budget))
    assert len(mesh.path) > 2  # not the straight line (checked before the first iteration)
    assert at_once.log["spheres_fallback_iteration"] == 1.0
    np.testing.assert_array_equal(at_once.path, mesh.path)
    for bad in (-1, 2.5):
        with pytest.raises(InvalidInputError, match="fallback_iterations"):
            rrt_connect(space, req.start, req.goal, RRTConnectOptions(fallback_iterations=bad))  # type: ignore[arg-type]
