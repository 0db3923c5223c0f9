"""The batched sphere checks of the compiled kernel on robots other than the Panda.

The kernel (planning_kernel.cpp) checks configurations 4 at a time: its own forward kinematics
of revolute and prismatic joints about x, y or z from each joint's placement (skipping the
products with placement entries exactly 0 or 1), a single-precision filter (sphere_batch.hpp)
and the double-precision sphere test. The MotionBenchMaker Panda's joint placements are axis
permutations; here the robots are UR5 (placements with entries 4.9e-12 from rounded pi/2),
Baxter (two arms on one torso: a branching tree, placements turned by 45 degrees, prismatic
finger joints), Unitree Z1 (joints about x, y and z), SO-100 on a fixed base (placements
turned by 0.23 and 1 rad about x), an arm built here with prismatic joints
and joint placements turned by arbitrary and by tiny angles (entries between 1e-4 and 1e-3),
the same arm with an unaligned revolute joint (the kernel's Pinocchio kinematics), and the
Kinova arm (continuous joints, nq != nv: no compiled checker). References, independent of the
kernel's code:

* the double-precision sphere test recomputed with Pinocchio's forward kinematics
  (``_sphere_reference.PairClearances``): sphere-sphere, sphere-box, sphere-cylinder and
  sphere-ball distances in NumPy, coal's distance to other shapes;
* Pinocchio's ``computeCollisions`` on the collision geometry.
"""

from __future__ import annotations

import itertools
import warnings
from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest
from _sphere_reference import (
    PairClearances,
    first_sphere_contacts,
    last_step_pairs,
    mesh_collides,
)
from scipy.spatial import ConvexHull

from taskspace._native import planning_kernel
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    EdgeCheckOptions,
    bisection_order,
)
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

pytestmark = pytest.mark.skipif(
    planning_kernel() is None, reason="compiled planning kernel not built"
)

MESH, SPHERES, SPHERES_ONLY = 0, 1, 2
OFF, TRUSTED = 0, 2  # CollisionKernel.set_sphere_filter: double only; filter (default)
# where the kernel and the reference may legitimately differ: a primitive or self pair
# within 1e-9 m of touching (rounding), another shape (coal) within twice GJK's tolerance:
# the kernel counts a sphere within about 1e-6 m of such a shape as touching it (its first
# contacts there are at reference clearances 1e-6 + 1e-12)
BAND_PRIMITIVE, BAND_GJK, GJK_TOLERANCE = 1e-9, 2e-6, 1e-6
ROBOTS = ["ur5", "baxter", "z1", "so100", "skew_arm"]


def _rotation(axis: Any, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    return np.asarray(pin.exp3(angle * axis / np.linalg.norm(axis)))


def _skew_arm(unaligned: bool = False) -> Robot:
    """A 6-joint arm on a rail: prismatic x, revolute z, y, prismatic z, revolute x, z, with
    joint placements turned by arbitrary angles and by tiny ones (4e-4 and 7e-4 rad: entries
    between 1e-4 and 1e-3), box and capsule links, a static base box. ``unaligned``: the third
    joint revolves about an oblique axis (JointModelRevoluteUnaligned)."""
    rng = np.random.default_rng(4)
    model = pin.Model()
    joints = [
        (pin.JointModelPX(), _rotation(rng.standard_normal(3), 0.9), (0.0, 0.0, 0.1), -0.3, 0.3),
        (pin.JointModelRZ(), _rotation((1.0, 1.0, 0.0), 4e-4), (0.0, 0.0, 0.15), -2.8, 2.8),
        (
            pin.JointModelRevoluteUnaligned(0.3, 0.8, -0.52) if unaligned else pin.JointModelRY(),
            _rotation(rng.standard_normal(3), 1.7),
            (0.05, 0.0, 0.3),
            -2.0,
            2.0,
        ),
        (pin.JointModelPZ(), _rotation((1.0, 0.0, 0.0), np.deg2rad(37.0)), (0, 0, 0.25), 0, 0.15),
        (pin.JointModelRX(), _rotation(rng.standard_normal(3), 2.3), (0.0, 0.02, 0.2), -2.5, 2.5),
        (pin.JointModelRZ(), _rotation((0.2, 1.0, 0.1), 7e-4), (0.0, 0.0, 0.12), -3.0, 3.0),
    ]
    for i, (joint, rotation, translation, lo, hi) in enumerate(joints):
        placement = pin.SE3(rotation, np.array(translation, dtype=float))
        model.addJoint(
            i,
            joint,
            placement,
            f"joint{i + 1}",
            np.array([50.0]),
            np.array([2.0]),
            np.array([lo]),
            np.array([hi]),
        )
        model.appendBodyToJoint(i + 1, pin.Inertia.FromBox(1.0, 0.1, 0.1, 0.2), pin.SE3.Identity())
    geom = pin.GeometryModel()
    base = pin.GeometryObject(
        "base", 0, 0, pin.SE3(np.eye(3), np.array([0, 0, 0.02])), coal.Box(0.3, 0.3, 0.04)
    )
    geom.addGeometryObject(base)
    for j in range(1, 7):
        if j % 2:
            shape: Any = coal.Capsule(0.04, 0.14)
        else:
            shape = coal.Box(0.07, 0.05, 0.16)
        at = pin.SE3(_rotation(rng.standard_normal(3), 0.3), np.array([0.0, 0.0, 0.08]))
        geom.addGeometryObject(pin.GeometryObject(f"link{j}", j, 0, at, shape))
    parents = [0, *[o.parentJoint for o in geom.geometryObjects][1:]]
    for a in range(geom.ngeoms):
        for b in range(a + 1, geom.ngeoms):
            if abs(parents[a] - parents[b]) > 1:  # not the same or adjacent links
                geom.addCollisionPair(pin.CollisionPair(a, b))
    name = "skew_arm_unaligned" if unaligned else "skew_arm"
    return Robot(model, geom, geom, name=name)


# obstacles near each arm's reach (base frame): boxes, a ball, a cylinder
OBSTACLES = {
    "ur5": [
        Obstacle.box("table", [1.2, 1.2, 0.05], (0.0, 0.0, -0.06)),
        Obstacle.box("block", [0.2, 0.3, 0.1], (0.45, 0.1, 0.3)),
        Obstacle.sphere("ball", 0.1, (-0.3, 0.35, 0.5)),
        Obstacle.cylinder("post", 0.05, 0.6, (0.2, -0.45, 0.4)),
    ],
    "baxter": [
        Obstacle.box("table", [0.6, 1.4, 0.05], (0.85, 0.0, -0.2)),
        Obstacle.sphere("ball", 0.1, (0.75, 0.3, 0.25)),
        Obstacle.cylinder("post", 0.05, 0.8, (0.7, -0.45, 0.1)),
    ],
    "z1": [
        Obstacle.box("block", [0.12, 0.2, 0.08], (0.35, 0.05, 0.25)),
        Obstacle.sphere("ball", 0.06, (-0.2, 0.25, 0.35)),
        Obstacle.cylinder("post", 0.03, 0.5, (0.15, -0.3, 0.25)),
    ],
    "so100": [
        Obstacle.box("block", [0.08, 0.06, 0.05], (0.08, -0.2, 0.12)),
        Obstacle.sphere("ball", 0.03, (-0.1, -0.15, 0.25)),
        Obstacle.cylinder("post", 0.015, 0.3, (0.1, -0.05, 0.15)),
    ],
    "skew_arm": [
        Obstacle.box("block", [0.2, 0.2, 0.1], (0.35, 0.1, 0.6)),
        Obstacle.sphere("ball", 0.08, (-0.25, 0.2, 0.7)),
        Obstacle.cylinder("post", 0.04, 0.6, (0.1, -0.4, 0.5)),
    ],
}


# self pairs whose spheres touch at every configuration (the spheres' margin closes the gap
# between neighbouring links; their meshes do not touch): not checked here, so that every pair
# keeps the pure sphere test of this file's reference (the checker would test them exactly:
# CollisionChecker.sphere_exact_pairs, tests/planning/test_planning_sphere_exact_pairs.py)
DISABLED = {
    "z1": [("link03_1", "link04_0"), ("link04_0", "link06_0"), ("link06_0", "gripperMover_0")]
}


class Scene:
    """A robot with obstacles, its compiled checker with spheres, the references."""

    def __init__(self, name: str, extra: list[Obstacle] | None = None) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # example-robot-data's missing limits...
            if name.startswith("skew_arm"):
                self.robot = _skew_arm(unaligned=name.endswith("unaligned"))
            else:
                base = "fixed" if name == "so100" else None  # its loader's free flyer off
                self.robot = Robot.load(name, convex_collision=True, base=base)
        self.robot.add_obstacles(OBSTACLES[name.removesuffix("_unaligned")] + (extra or []))
        self.robot.disable_collision_pairs(DISABLED.get(name, []))
        self.space = ConfigurationSpace.from_robot(
            self.robot, edge=EdgeCheckOptions(resolution=0.03)
        )
        self.kernel = self.space.checker.sphere_kernel()
        assert self.kernel is not None
        self.reference = PairClearances(
            self.robot, self.space.checker.sphere_model(), self.space.checker.sphere_exact_pairs
        )
        self.mesh = mesh_collides(self.robot)
        self.lo = self.robot.model.lowerPositionLimit
        self.hi = self.robot.model.upperPositionLimit

    def random(self, seed: int, n: int) -> np.ndarray:
        return np.random.default_rng(seed).uniform(self.lo, self.hi, (n, self.robot.nq))

    def first_contacts(self, qs: np.ndarray, seed: int, count: int) -> np.ndarray:
        """Configurations within 1e-12 of the first sphere contact (first_sphere_contacts)."""
        return first_sphere_contacts(self.kernel, qs, np.random.default_rng(seed), count)

    def clearances(self, qs: np.ndarray) -> np.ndarray:
        """Per row: the reference's smallest sphere clearance to primitives and self pairs,
        and to the other shapes [m]."""
        return np.array([self.reference.clearance(q) for q in qs])


_SCENES: dict[str, Scene] = {}


@pytest.fixture(scope="module")
def scenes() -> dict[str, Scene]:
    return _SCENES


def _scene(scenes: dict[str, Scene], name: str) -> Scene:
    if name not in scenes:
        scenes[name] = Scene(name)
    return scenes[name]


def _reference_flags(clearance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(colliding per the reference, decided: outside the bands where both may differ)."""
    prim, other = clearance[:, 0], clearance[:, 1]
    colliding = (prim <= 0.0) | (other <= 0.0)
    decided = (np.abs(prim) > BAND_PRIMITIVE) & (np.abs(other) > BAND_GJK)
    return colliding, decided


def _test_set(scene: Scene, seed: int) -> tuple[np.ndarray, int]:
    """Random configurations, first contacts and the contacts moved by 1e-7 to 1e-4 rad (or
    m); the number of random rows."""
    qs = scene.random(seed, 160)
    contacts = scene.first_contacts(qs, seed, 16)
    rng = np.random.default_rng(seed + 1)
    scale = np.repeat([1e-7, 1e-6, 1e-5, 1e-4], 4)[:, None]
    shifted = np.clip(contacts + rng.standard_normal(contacts.shape) * scale, scene.lo, scene.hi)
    return np.vstack([qs, contacts, shifted]), len(qs)


@pytest.mark.parametrize("name", ROBOTS)
def test_spheres_only_is_the_reference_sphere_test(scenes: dict[str, Scene], name: str) -> None:
    """collisions_with(rows, spheres only) flags a row iff some sphere clearance of the
    reference is <= 0 (outside the rounding bands); the kernel's first contacts are the
    reference's (a wrong joint placement moves them by far more than 1e-6 m); the filter
    never clears a row the reference finds colliding, nor one the double test flags."""
    scene = _scene(scenes, name)
    kernel = scene.kernel
    assert kernel.sphere_filter() and kernel.sphere_filter_mode == TRUSTED
    allq, n_random = _test_set(scene, 11)
    clearance = scene.clearances(allq)
    colliding, decided = _reference_flags(clearance)
    flags = kernel.collisions_with(allq, SPHERES_ONLY).astype(bool)
    wrong = np.flatnonzero(decided & (flags != colliding))
    assert wrong.size == 0, [(int(i), flags[i], clearance[i].tolist()) for i in wrong[:5]]
    assert decided.sum() >= len(allq) - 16 - 12  # the contacts are in the bands
    assert 0 < colliding[:n_random].sum() < n_random  # both answers among the random rows
    # at the kernel's first contacts, the reference's spheres touch too
    depth = clearance[n_random : n_random + 16].min(axis=1)
    assert np.all(depth <= GJK_TOLERANCE + BAND_PRIMITIVE), depth
    assert np.all(depth > -GJK_TOLERANCE), depth
    filtered = kernel.sphere_filter_flags(allq).astype(bool)
    assert np.all(filtered[colliding]) and np.all(filtered[flags])
    # without the filter: the same answers
    kernel.set_sphere_filter(OFF)
    try:
        np.testing.assert_array_equal(kernel.collisions_with(allq, SPHERES_ONLY), flags)
    finally:
        kernel.set_sphere_filter(TRUSTED)


@pytest.mark.parametrize("name", ROBOTS)
def test_spheres_then_narrow_phase_is_pinocchio(scenes: dict[str, Scene], name: str) -> None:
    """collisions_with(rows, spheres) (the exact narrow phase where spheres touch) and the
    exact checker equal Pinocchio's computeCollisions row by row; first_invalid_on_edge with
    the sphere checker is the first index (in bisection order) that Pinocchio finds colliding."""
    scene = _scene(scenes, name)
    kernel = scene.kernel
    assert kernel.certified_margin > 0.0  # the spheres cover the geometry: certified
    allq, n_random = _test_set(scene, 12)
    mesh = np.array([scene.mesh(q) for q in allq])
    np.testing.assert_array_equal(kernel.collisions_with(allq, SPHERES).astype(bool), mesh)
    np.testing.assert_array_equal(kernel.collisions_with(allq, MESH).astype(bool), mesh)
    assert 0 < mesh[:n_random].sum() < n_random
    n = 13
    order = bisection_order(n)
    found = 0
    rng = np.random.default_rng(13)
    free = allq[:n_random][~mesh[:n_random]]
    for k in range(min(12, len(free))):
        a = free[k]
        b = np.clip(a + rng.standard_normal(len(a)) * 0.4, scene.lo, scene.hi)
        expect = next((j for j in order if scene.mesh(a + j / n * (b - a))), -1)
        assert kernel.first_invalid_on_edge(a, b, n, SPHERES) == expect
        found += expect >= 0
    assert found > 0


@pytest.mark.parametrize("name", ROBOTS)
def test_simd_levels_give_the_same_answers(scenes: dict[str, Scene], name: str) -> None:
    """Every SIMD level of this processor (set_simd: 1 SSE2, 2 AVX2 with FMA, 3 AVX-512): the
    same answers, bit for bit, on random rows and on the two sides of the last representable
    step before sphere contact, with and without the filter, and the same first colliding
    edge indices; each level's filter mask holds every row the double test finds colliding
    (the filter's builds round differently: FMA from level 2 on)."""
    scene = _scene(scenes, name)
    kernel = scene.kernel
    initial = kernel.simd
    levels = list(range(1, type(kernel).max_simd + 1))
    qs = scene.random(14, 120)
    kernel.set_sphere_filter(OFF)
    try:
        hit = kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)
    finally:
        kernel.set_sphere_filter(TRUSTED)
    free, hit_rows = qs[~hit], qs[hit]
    count = min(10, len(free), len(hit_rows))
    allq = np.vstack([qs, last_step_pairs(kernel, free, hit_rows, count)])
    out = {}
    masks = {}
    try:
        for level in levels:
            kernel.set_simd(level)
            row = []
            for mode in (OFF, TRUSTED):
                kernel.set_sphere_filter(mode)
                row += [kernel.collisions_with(allq, c) for c in (SPHERES, SPHERES_ONLY)]
                row.append(
                    [kernel.first_invalid_on_edge(qs[k], qs[k + 1], 15, 2) for k in range(20)]
                )
            out[level] = row
            masks[level] = kernel.sphere_filter_flags(allq).astype(bool)
    finally:
        kernel.set_simd(initial)
        kernel.set_sphere_filter(TRUSTED)
    assert kernel.simd == initial
    for level in levels:
        for x, y in zip(out[1], out[level], strict=True):
            np.testing.assert_array_equal(x, y)
        assert np.all(masks[level][out[1][1].astype(bool)])
    boundary = out[1][1][len(qs) :]  # the double test at the two sides of each contact
    assert boundary[0::2].sum() == 0 and boundary[1::2].all()


@pytest.mark.parametrize("name", ROBOTS)
def test_compiled_rrt_connect_paths_are_free(scenes: dict[str, Scene], name: str) -> None:
    """The compiled RRT-Connect with the spheres-only checker between two free configurations
    about 0.6 rad apart whose straight line collides: its path is free for Pinocchio at 0.01
    rad (or m)."""
    scene = _scene(scenes, name)
    kernel = scene.kernel
    rng = np.random.default_rng(15)
    qs = scene.random(15, 200)
    free = qs[~kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)]
    goals = np.clip(free + rng.standard_normal(free.shape) * 0.6, scene.lo, scene.hi)
    start, goal = next(
        (a, b)
        for a, b in zip(free, goals, strict=True)
        if not kernel.collisions_with(b[None], SPHERES_ONLY)[0]
        and kernel.first_invalid_on_edge(a, b, 40, SPHERES) >= 0
    )
    opts = RRTConnectOptions(seed=1, checker="spheres_only", validator="spheres")
    res = rrt_connect(scene.space, start, goal, opts)
    assert res.success
    assert res.log["native"] == 1.0
    path = np.array(res.path)
    np.testing.assert_array_equal(path[0], start)
    np.testing.assert_array_equal(path[-1], goal)
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.abs(b - a).max() / 0.01)))
        assert not any(scene.mesh(a + t * (b - a)) for t in np.linspace(0.0, 1.0, n + 1))


def _convex_obstacle(name: str, seed: int, position: Any) -> Obstacle:
    """A convex hull of random points (coal.Convex) as an obstacle."""
    points = np.random.default_rng(seed).uniform(-0.06, 0.06, (20, 3))
    hull = ConvexHull(points).simplices.astype(np.int64)
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(hull), len(points))
    mesh.addVertices(points)
    mesh.addTriangles(hull)
    mesh.endModel()
    mesh.buildConvexHull(True, "Qt")
    return Obstacle(name, mesh.convex, pin.SE3(np.eye(3), np.asarray(position, dtype=float)))


def test_more_than_64_obstacles_and_other_shapes(scenes: dict[str, Scene]) -> None:
    """The UR5 with 70 obstacles (the kernel's link masks hold 64 static partners, the filter's
    per-link units 64 obstacles: the others are always tested), among them a capsule and a
    convex hull (coal's sphere tests): the spheres-only answers are the reference's, the
    filter is conservative, "spheres" and the exact checker are Pinocchio's."""
    if "ur5_many" not in scenes:
        # small cubes on the half sphere of radius 0.9 m (the UR5 reaches 0.95 m)
        rng = np.random.default_rng(18)
        out = rng.standard_normal((64, 3))
        out[:, 2] = np.abs(out[:, 2])
        out *= 0.9 / np.linalg.norm(out, axis=1)[:, None]
        extra = [Obstacle.box(f"cube{i}", [0.04] * 3, tuple(p)) for i, p in enumerate(out)]
        extra += [
            Obstacle(
                "capsule", coal.Capsule(0.04, 0.3), pin.SE3(np.eye(3), np.array([0.3, 0.3, 0.3]))
            ),
            _convex_obstacle("hull", 19, (-0.35, -0.2, 0.45)),
        ]
        scenes["ur5_many"] = Scene("ur5", extra)
    scene = scenes["ur5_many"]
    kernel = scene.kernel
    assert len(scene.robot.world) == 70
    allq, n_random = _test_set(scene, 20)
    clearance = scene.clearances(allq)
    colliding, decided = _reference_flags(clearance)
    flags = kernel.collisions_with(allq, SPHERES_ONLY).astype(bool)
    assert np.all(flags[decided] == colliding[decided])
    assert decided.sum() >= len(allq) - 16 - 12
    assert 0 < colliding[:n_random].sum() < n_random
    depth = clearance[n_random : n_random + 16].min(axis=1)
    assert np.all(depth <= GJK_TOLERANCE + BAND_PRIMITIVE), depth
    assert np.all(depth > -GJK_TOLERANCE), depth
    filtered = kernel.sphere_filter_flags(allq).astype(bool)
    assert np.all(filtered[colliding]) and np.all(filtered[flags])
    mesh = np.array([scene.mesh(q) for q in allq])
    np.testing.assert_array_equal(kernel.collisions_with(allq, SPHERES).astype(bool), mesh)
    np.testing.assert_array_equal(kernel.collisions_with(allq, MESH).astype(bool), mesh)


def test_unaligned_joint_uses_pinocchio_kinematics_with_the_same_answers(
    scenes: dict[str, Scene],
) -> None:
    """A revolute joint about an oblique axis (not x, y or z): the kernel's sphere checkers
    (Pinocchio's kinematics then, one configuration at a time) still give the reference's
    answers and Pinocchio's."""
    scene = _scene(scenes, "skew_arm_unaligned")
    kernel = scene.kernel
    allq = np.vstack([scene.random(16, 120), scene.first_contacts(scene.random(17, 60), 17, 8)])
    clearance = scene.clearances(allq)
    colliding, decided = _reference_flags(clearance)
    flags = kernel.collisions_with(allq, SPHERES_ONLY).astype(bool)
    assert np.all(flags[decided] == colliding[decided])
    assert 0 < colliding.sum() < len(allq)
    mesh = np.array([scene.mesh(q) for q in allq])
    np.testing.assert_array_equal(kernel.collisions_with(allq, SPHERES).astype(bool), mesh)


def test_continuous_joints_take_the_python_path() -> None:
    """The Kinova arm (continuous joints: nq 9 > nv 6): no compiled checker (None), and
    RRT-Connect asked for the spheres-only checker plans with Pinocchio's checks instead; its
    path (interpolated on the joints' manifold) is free for Pinocchio."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("kinova", convex_collision=True)
    robot.add_obstacles([Obstacle.sphere("ball", 0.1, (0.5, -0.5, 0.2))])
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    assert robot.nq != robot.model.nv
    assert space.checker.sphere_kernel() is None
    q0 = robot.q_default
    q1 = pin.integrate(robot.model, q0, np.full(robot.model.nv, 0.3))
    opts = RRTConnectOptions(seed=1, checker="spheres_only", validator="spheres")
    res = rrt_connect(space, q0, q1, opts)
    assert res.success
    assert "native" not in res.log
    mesh = mesh_collides(robot)
    for a, b in itertools.pairwise(res.path):
        dv = pin.difference(robot.model, a, b)
        n = max(1, int(np.ceil(np.abs(dv).max() / 0.01)))
        assert not any(
            mesh(pin.interpolate(robot.model, a, b, t)) for t in np.linspace(0.0, 1.0, n + 1)
        )


@pytest.mark.parametrize("name", ROBOTS)
def test_float_placements_against_pinocchio(scenes: dict[str, Scene], name: str) -> None:
    """The filter's single-precision joint placements (SphereFilter::load_q) against Pinocchio's
    forwardKinematics in double, at every SIMD level: a serial chain (registers), a tree
    (baxter: the general chain) and prismatic joints between revolute ones with turned joint
    frames (skew_arm). Rotations within the header's 21 d u (Frobenius), translations within
    its sphere-centre bound (35 n + 20.3) u S (u = 2^-24, d the joint's depth, n the chain's)."""
    scene = _scene(scenes, name)
    kernel, model = scene.kernel, scene.robot.model
    data = model.createData()
    scale, n = kernel.sphere_filter_bound()
    depth = [0] * model.njoints
    for j in range(1, model.njoints):
        depth[j] = depth[model.parents[j]] + 1
    assert n == max(depth)
    u = 2.0**-24
    qs = np.vstack([scene.random(5, 150), scene.lo, scene.hi, np.zeros(model.nq)])
    initial = kernel.simd
    try:
        for level in range(1, type(kernel).max_simd + 1):
            kernel.set_simd(level)
            placements = kernel.sphere_filter_placements(qs)
            assert placements.shape == (len(qs), 12 * model.njoints)
            for q, row in zip(qs, placements, strict=True):
                pin.forwardKinematics(model, data, q)
                for j in range(1, model.njoints):
                    m = data.oMi[j]
                    rot = row[12 * j : 12 * j + 9].reshape(3, 3)
                    assert np.linalg.norm(rot - m.rotation) <= 21.0 * depth[j] * u, (level, j)
                    t = row[12 * j + 9 : 12 * j + 12]
                    error = np.linalg.norm(t - m.translation)
                    assert error <= (35.0 * n + 20.3) * u * scale, (level, j, error)
    finally:
        kernel.set_simd(initial)
