"""Objects built from a robot follow ``Robot.edit_model`` and ``Robot.edit_collision_model``.

Issue #15 item 1. The derived objects not covered by ``test_model_ownership.py``: a
``State``'s collision distances and the ``CollisionDistance`` feature (after an obstacle or a
shape change without ``state.update``), the locked-joint checker and its compiled kernel,
and PRM / Lazy PRM roadmaps (refused after either edit).

References: Pinocchio's ``computeDistances`` / ``computeCollisions`` on copies of the models
edited here by hand, with full configurations assembled here from the joint slices.
"""

from __future__ import annotations

import warnings

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import PlanningError, StaleModelError
from taskspace.features import CollisionDistance
from taskspace.model import Obstacle, Robot
from taskspace.planning import ConfigurationSpace
from taskspace.planning.lazy_prm import lazy_prm, lazy_prm_query
from taskspace.planning.prm import PRMOptions, build_prm, prm_query

RAISE = 0.4  # [m] the model edit: the panda's first joint raised by this much
LOCKED = {"panda_joint2": 0.9, "panda_joint7": -1.2}
HAND = "panda_hand_0"


_LOADED: dict[bool, Robot] = {}


def _panda(convex: bool = False) -> Robot:
    """A panda of its own (these tests edit it), made from the models of one loaded panda."""
    if convex not in _LOADED:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _LOADED[convex] = Robot.load("panda", convex_collision=convex)
    base = _LOADED[convex]
    return Robot(
        base.model,
        base.collision_model,
        base.visual_model,
        name="panda",
        default_configuration=base.q_default,
    )


def _raise(model: pin.Model) -> None:
    placement = pin.SE3(model.jointPlacements[1])
    placement.translation = placement.translation + np.array([0.0, 0.0, RAISE])
    model.jointPlacements[1] = placement


def _distances(model: pin.Model, geom: pin.GeometryModel, q: np.ndarray) -> np.ndarray:
    data, gdata = model.createData(), geom.createData()
    pin.computeDistances(model, data, geom, gdata, q)
    return np.array([r.min_distance for r in gdata.distanceResults])


def _collides(model: pin.Model, geom: pin.GeometryModel, q: np.ndarray) -> bool:
    return bool(pin.computeCollisions(model, model.createData(), geom, geom.createData(), q, True))


def _assemble(model: pin.Model, free: np.ndarray) -> np.ndarray:
    """The full configuration from the free coordinates and LOCKED (reference)."""
    q = np.empty(model.nq)
    it = iter(free.tolist())
    for j in range(1, model.njoints):
        joint = model.joints[j]
        name = str(model.names[j])
        q[joint.idx_q] = LOCKED[name] if name in LOCKED else next(it)
    return q


# ---------------------------------------------------------------------- state and feature
def test_state_distances_follow_the_world_without_an_update() -> None:
    robot = _panda(convex=True)
    q = robot.q_default.copy()
    state = robot.state(q)
    before = [r.min_distance for r in state.distance_results()]
    assert np.allclose(before, _distances(robot.model, robot.collision_model, q))
    # an obstacle: more pairs, the state is not updated
    robot.add_obstacle(Obstacle.sphere("ball", 0.05, [0.45, 0.0, 0.6]))
    now = [r.min_distance for r in state.distance_results()]
    assert len(now) == len(robot.collision_pairs) > len(before)
    assert np.allclose(now, _distances(robot.model, robot.collision_model, q), rtol=0, atol=1e-9)
    # a shape grown through the sanctioned route
    reference = robot.collision_model.copy()
    gid = reference.getGeometryId(HAND)
    reference.geometryObjects[gid].geometry = coal.Sphere(0.25)
    with robot.edit_collision_model() as geom:
        geom.geometryObjects[gid].geometry = coal.Sphere(0.25)
    expected = _distances(robot.model, reference, q)
    assert not np.allclose(expected, now)
    got = [r.min_distance for r in state.distance_results()]
    assert np.allclose(got, expected, rtol=0, atol=1e-9)


def test_collision_distance_feature_follows_the_world_without_an_update() -> None:
    robot = _panda(convex=True)
    robot.add_obstacle(Obstacle.sphere("ball", 0.05, [0.45, 0.0, 0.6]))
    q = robot.q_default.copy()
    feature = CollisionDistance(robot, [(HAND, "ball")])
    state = robot.state(q)
    first = float(feature.value(state)[0])
    # another obstacle first in the pair order shifts the indices; then the hand grows
    robot.add_obstacle(Obstacle.box("shelf", [0.2, 0.2, 0.02], [0.0, 0.5, 0.3]))
    with robot.edit_collision_model() as geom:
        geom.geometryObjects[geom.getGeometryId(HAND)].geometry = coal.Sphere(0.15)
    reference = robot.collision_model.copy()
    k = robot.collision_pairs.index((HAND, "ball"))
    expected = _distances(robot.model, reference, q)[k]
    assert abs(expected - first) > 0.01
    assert float(feature.value(state)[0]) == pytest.approx(expected, abs=1e-9)


# ---------------------------------------------------------------------- locked-joint checker
@pytest.fixture()
def panda_table() -> Robot:
    robot = _panda()
    robot.add_obstacle(Obstacle.box("block", [0.3, 0.6, 0.3], [0.55, 0.0, 0.35]))
    robot.add_obstacle(Obstacle.box("plate", [1.2, 1.2, 0.05], [0.0, 0.0, 1.35]))
    return robot


@pytest.mark.parametrize("native", [False, True])
def test_locked_joint_checker_follows_edit_model_and_edit_collision_model(
    panda_table: Robot, native: bool
) -> None:
    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    free = space.sample_uniform(np.random.default_rng(5), 200)

    def answers() -> np.ndarray:
        if native:
            kernel = space.checker.native_kernel()
            if kernel is None:
                pytest.skip("compiled planning kernel not built")
            return np.asarray(kernel.collisions(free)) == 0
        return np.asarray(space.checker.are_valid(free))

    def reference(model: pin.Model, geom: pin.GeometryModel) -> np.ndarray:
        return np.array([not _collides(model, geom, _assemble(model, f)) for f in free])

    before = reference(robot.model, robot.collision_model)
    np.testing.assert_array_equal(answers(), before)

    model = robot.model.copy()  # the hand-edited reference
    _raise(model)
    with robot.edit_model() as m:
        _raise(m)
    raised = reference(model, robot.collision_model)
    assert np.any(raised != before)
    np.testing.assert_array_equal(answers(), raised)

    geom = robot.collision_model.copy()
    gid = geom.getGeometryId(HAND)
    geom.geometryObjects[gid].geometry = coal.Sphere(0.3)
    with robot.edit_collision_model() as g:
        g.geometryObjects[gid].geometry = coal.Sphere(0.3)
    grown = reference(model, geom)
    assert np.any(grown != raised)
    np.testing.assert_array_equal(answers(), grown)


# ---------------------------------------------------------------------- roadmaps
@pytest.mark.parametrize("edit", ["model", "collision_model"])
def test_roadmaps_are_refused_after_an_edit(edit: str) -> None:
    robot = _panda()
    space = ConfigurationSpace.from_robot(robot)
    options = PRMOptions(max_iterations=30, k_neighbors=5, seed=3)
    roadmap = build_prm(space, options)
    _, lazy = lazy_prm(space, robot.q_default, robot.q_default, options)
    start, goal = roadmap.nodes[0], roadmap.nodes[1]
    prm_query(space, roadmap, start, goal, options)
    lazy_prm_query(space, lazy, start, goal, options)
    if edit == "model":
        with robot.edit_model() as m:
            _raise(m)
        error: type[Exception] = StaleModelError
    else:
        with robot.edit_collision_model() as g:
            g.geometryObjects[g.getGeometryId(HAND)].geometry = coal.Sphere(0.3)
        error = PlanningError
    with pytest.raises(error, match="roadmap was built for"):
        prm_query(space, roadmap, start, goal, options)
    with pytest.raises(error, match="roadmap was built for"):
        lazy_prm_query(space, lazy, start, goal, options)


# ---------------------------------------------------------------------- public attributes
def test_derived_objects_hand_out_the_robots_copies_not_its_objects() -> None:
    from taskspace.dynamics.forward_dynamics import ForwardDynamics
    from taskspace.planning.joint_manifold import JointManifold
    from taskspace.viz.viewer import Viewer

    robot = _panda(convex=True)
    q = robot.q_default.copy()
    reference_model = robot.model.copy()  # untouched
    reference_geom = robot.collision_model.copy()
    for obj in reference_geom.geometryObjects:  # pin's copy shares the shapes: clone them
        obj.geometry = obj.geometry.clone()
    frame = reference_model.getFrameId("panda_hand_tcp")
    version, world_version = robot.version, robot.world.version
    models = [ForwardDynamics(robot).model, JointManifold(robot).model]
    for model in models:
        _raise(model)  # an edit of what the object hands out
    viewer = Viewer(robot, q, geometry="collision")
    hand = viewer.geometry_model.geometryObjects[reference_geom.getGeometryId(HAND)]
    hand.geometry.points()[:] *= 5.0
    viewer.geometry_model.removeAllCollisionPairs()

    data = robot._model.createData()
    pin.framesForwardKinematics(robot._model, data, q)
    ref_data = reference_model.createData()
    pin.framesForwardKinematics(reference_model, ref_data, q)
    assert data.oMf[frame].isApprox(ref_data.oMf[frame], 1e-14)
    assert np.allclose(
        _distances(robot._model, robot._collision_model, q),
        _distances(reference_model, reference_geom, q),
        rtol=0,
        atol=1e-12,
    )
    assert (robot.version, robot.world.version) == (version, world_version)


def test_pendulum_env_steps_with_the_edited_model() -> None:
    from taskspace.learning.envs import PendulumEnv

    env = PendulumEnv(max_torque=5.0, substeps=5)
    env.reset(seed=0)
    reference = env.robot.model.copy()  # the hand edit: a 3x heavier pendulum
    jid = reference.njoints - 1
    inertia = reference.inertias[jid]
    heavier = pin.Inertia(3.0 * inertia.mass, inertia.lever, 3.0 * inertia.inertia)
    reference.inertias[jid] = heavier
    with env.robot.edit_model() as model:
        model.inertias[jid] = heavier
    env.state = np.array([1.0, 0.0])
    q, v, h = np.array([1.0]), np.zeros(1), env.dt / 5
    data = reference.createData()
    for tau in (2.0, -1.0, 0.5):
        env.step(np.array([tau], dtype=np.float32))
        for _ in range(5):
            v = np.clip(v + h * pin.aba(reference, data, q, v, np.array([tau])), -8.0, 8.0)
            q = q + h * v
        assert env.state == pytest.approx([q[0], v[0]], abs=1e-9)


# ---------------------------------------------------------------------- compiled dampers
def test_compiled_collision_dampers_follow_both_edits() -> None:
    from taskspace import features as F
    from taskspace._native import ik_kernel
    from taskspace.constraints import CollisionAvoidance
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.tasks import Task

    if ik_kernel() is None:
        pytest.skip("compiled IK kernel not built")
    influence = 0.12
    robot = _panda(convex=True)
    tcp = robot.frame_id("panda_hand_tcp")
    state = robot.state(robot.q_default)
    target = state.frame_placement(tcp).copy()
    robot.add_obstacle(
        Obstacle.sphere("ball", 0.07, target.translation + np.array([0.0, 0.22, -0.03]))
    )
    pose = Task(F.FramePose(robot, "panda_hand_tcp"), target, weight=1.0, gain=0.5)
    avoid = CollisionAvoidance(robot, safety_distance=0.02, influence_distance=influence)
    ik = DifferentialIK(robot, [pose], [avoid], options=DifferentialIKOptions(native=True))

    seen: list[np.ndarray] = []

    def check(model: pin.Model, geom: pin.GeometryModel) -> None:
        state.update(robot.q_default)
        result = ik.solve(state, 0.01)
        assert result.success and result.qp.backend == "native"
        _, _, _, pairs, dists = ik._native.damper_rows()
        d = _distances(model, geom, robot.q_default)
        expected = [k for k in range(len(d)) if d[k] < influence]
        assert list(pairs) == expected
        np.testing.assert_allclose(dists, d[expected], rtol=0, atol=1e-9)
        assert all(not np.allclose(d, other) for other in seen)  # each edit changes them
        seen.append(d)

    model, geom = robot.model.copy(), robot.collision_model.copy()
    check(model, geom)
    gid = geom.getGeometryId(HAND)
    geom.geometryObjects[gid].geometry = coal.Sphere(0.09)
    with robot.edit_collision_model() as g:
        g.geometryObjects[gid].geometry = coal.Sphere(0.09)
    check(model, geom)
    _raise(model)
    with robot.edit_model() as m:
        _raise(m)
    check(model, geom)


# ---------------------------------------------------------------------- the robot's world
def test_the_robots_world_changes_only_through_the_robot() -> None:
    from taskspace.errors import InvalidInputError
    from taskspace.model import World
    from taskspace.planning.collision_checker import CollisionChecker

    robot = _panda()
    q = robot.q_default.copy()
    untouched_model, untouched_geom = robot.model.copy(), robot.collision_model.copy()
    assert not _collides(untouched_model, untouched_geom, q)
    checker = CollisionChecker(robot)
    # a 3 m sphere around the base engulfs the arm: every configuration collides
    robot.world.add(Obstacle.sphere("engulf", 3.0, [0.0, 0.0, 0.0]))
    assert robot.collision_model.getGeometryId("engulf") < robot.collision_model.ngeoms
    assert not robot.is_collision_free(q) and not checker.is_valid(q)
    assert _collides(robot.model, robot.collision_model, q)
    robot.world.remove("engulf")
    assert robot.is_collision_free(q) and checker.is_valid(q)
    robot.world.add(Obstacle.sphere("engulf", 3.0, [0.0, 0.0, 0.0]))
    robot.world.clear()
    assert len(robot.world) == 0 and robot.collision_model.ngeoms == untouched_geom.ngeoms
    assert robot.is_collision_free(q) and checker.is_valid(q)
    with pytest.raises(AttributeError):
        robot.world = World([Obstacle.sphere("engulf", 3.0, [0.0, 0.0, 0.0])])  # type: ignore[misc]
    with pytest.raises(InvalidInputError, match="already exists"):
        robot.add_obstacle(Obstacle.sphere("a", 0.1, [2.0, 0.0, 0.0]))
        robot.world.add(Obstacle.sphere("a", 0.1, [2.0, 0.0, 0.0]))
    assert robot.collision_model.ngeoms == untouched_geom.ngeoms + 1
