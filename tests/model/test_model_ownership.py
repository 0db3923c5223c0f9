"""The robot owns its Pinocchio objects: edits go through it and every derived object follows.

Issue #15 item 1 ("invalidation by construction"). ``robot.model``, ``robot.collision_model``
and ``robot.visual_model`` are copies, so an edit made on them changes nothing of the robot
and of the objects built from it; :meth:`Robot.edit_model` and
:meth:`Robot.edit_collision_model` write edits into the robot, which gets a new version (and
its world a new one), and states, collision checkers, configuration spaces, the compiled
planner, the armed IK kernel and the inverse-dynamics QP compute with the new values.

References, independent of the robot's objects: Pinocchio's algorithms on a copy of the model
that the test edits by hand (``framesForwardKinematics``, ``computeCollisions``, ``rnea``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import JointPositionLimits
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Obstacle, Robot
from taskspace.planning import CollisionCheckerOptions, ConfigurationSpace
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.tasks import Task

RAISE = 0.4  # [m] the edit: panda's first joint (the whole arm) raised by this much
TCP = "panda_hand_tcp"


def _fresh(geometry: bool = False) -> Robot:
    """A panda of its own (these tests edit it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("panda", geometry=geometry, convex_collision=geometry)


def _raised(model: pin.Model) -> pin.Model:
    """The reference edit, made by hand on a copy: the first joint raised by ``RAISE``."""
    model = model.copy()
    placement = pin.SE3(model.jointPlacements[1])
    placement.translation = placement.translation + np.array([0.0, 0.0, RAISE])
    model.jointPlacements[1] = placement
    return model


def _raise(robot: Robot) -> None:
    """The same edit through the sanctioned route."""
    with robot.edit_model() as model:
        placement = pin.SE3(model.jointPlacements[1])
        placement.translation = placement.translation + np.array([0.0, 0.0, RAISE])
        model.jointPlacements[1] = placement


def _tcp(model: pin.Model, q: np.ndarray) -> np.ndarray:
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return np.asarray(data.oMf[model.getFrameId(TCP)].translation).copy()


def _collides(model: pin.Model, geom: pin.GeometryModel, q: np.ndarray) -> bool:
    return bool(pin.computeCollisions(model, model.createData(), geom, geom.createData(), q, True))


# ---------------------------------------------------------------------- edits of the copies
def test_in_place_edits_of_the_public_objects_change_nothing() -> None:
    robot = _fresh(geometry=True)
    q = robot.q_default.copy()
    reference = robot.model.copy()  # taken before anything is edited
    tcp = _tcp(reference, q)
    version, world_version = robot.version, robot.world.version
    lower, pairs = robot.lower_limits.copy(), robot.collision_pairs
    state = robot.state(q)
    ik = DifferentialIK(robot, [Task(F.Position(robot, TCP), tcp + 0.05)], [])
    dq_before = ik.solve(state, 0.1).dq
    free_before = robot.is_collision_free(q)
    controller = InverseDynamicsQP(robot, [Task(F.JointConfiguration(robot), q, kp=0.0, kd=0.0)])
    at_rest = robot.state(q, np.zeros(robot.nv))
    tau_before = controller.solve(at_rest).tau
    space = ConfigurationSpace.from_robot(robot)
    q_far = q.copy()
    q_far[3] = robot.upper_limits[3] - 0.01
    valid_before = [space.is_valid(q), space.is_valid(q_far)]

    model = robot.model
    model.jointPlacements[1] = _raised(reference).jointPlacements[1]
    model.lowerPositionLimit[0] = 0.0
    model.inertias[3] = pin.Inertia.Random()
    geom = robot.collision_model
    first = geom.collisionPairs[0]
    geom.removeCollisionPair(first)
    geom.geometryObjects[0].placement = pin.SE3.Random()

    assert (robot.version, robot.world.version) == (version, world_version)
    np.testing.assert_array_equal(robot.lower_limits, lower)
    assert robot.collision_pairs == pairs
    np.testing.assert_array_equal(robot.frame_placement(q, TCP).translation, tcp)
    np.testing.assert_array_equal(
        robot.state(q).frame_placement(robot.frame_id(TCP)).translation, tcp
    )
    np.testing.assert_allclose(ik.solve(robot.state(q), 0.1).dq, dq_before, atol=1e-12)
    assert robot.is_collision_free(q) == free_before
    np.testing.assert_array_equal(controller.solve(at_rest).tau, tau_before)
    assert [space.is_valid(q), space.is_valid(q_far)] == valid_before
    assert space.lower[0] == lower[0]
    # after a change of the robot, the accessors hand out new copies of the robot's models
    robot.set_limits(lower=lower)
    robot.disable_collision_pairs([])
    assert robot.model is not model and robot.collision_model is not geom
    assert robot.model.jointPlacements[1] == reference.jointPlacements[1]
    assert robot.model.inertias[3] == reference.inertias[3]
    assert robot.collision_model.existCollisionPair(first)


def test_the_robot_copies_the_models_it_is_given() -> None:
    model = pin.buildSampleModelManipulator()
    geom = pin.buildSampleGeometryModelManipulator(model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot(model, geom, pin.GeometryModel(), name="sample")
    q = pin.neutral(model)
    before = robot.frame_placement(q, "effector_body").homogeneous.copy()
    model.jointPlacements[1] = pin.SE3(np.eye(3), np.array([0.0, 0.0, 1.0]))
    np.testing.assert_array_equal(robot.frame_placement(q, "effector_body").homogeneous, before)


def test_data_cannot_be_replaced() -> None:
    robot = _fresh()
    for name in ("data", "collision_data", "model", "collision_model", "visual_model"):
        with pytest.raises(AttributeError):
            setattr(robot, name, None)


# ---------------------------------------------------------------------- the sanctioned edit
def test_edit_model_bumps_the_version_and_states_follow() -> None:
    robot = _fresh()
    q = robot.q_default.copy()
    expected = _tcp(_raised(robot.model), q)
    state = robot.state(q)
    version, world_version = robot.version, robot.world.version
    _raise(robot)
    assert robot.version > version and robot.world.version != world_version
    np.testing.assert_allclose(robot.frame_placement(q, TCP).translation, expected, atol=1e-12)
    state.update(q)  # a state evaluated before the edit, evaluated again
    fid = robot.frame_id(TCP)
    np.testing.assert_allclose(state.frame_placement(fid).translation, expected, atol=1e-12)
    np.testing.assert_allclose(
        robot.state(q).frame_placement(fid).translation, expected, atol=1e-12
    )


@pytest.mark.parametrize("velocity", [False, True])
def test_states_evaluated_before_the_edit_are_re_evaluated(velocity: bool) -> None:
    """No update after the edit: the state's kinematics are already the edited model's."""
    robot = _fresh()
    q = robot.q_default.copy()
    v = np.linspace(-0.3, 0.3, robot.nv) if velocity else None
    model = _raised(robot.model)
    data = model.createData()
    fid = model.getFrameId(TCP)
    if velocity:
        pin.forwardKinematics(model, data, q, v)
        pin.updateFramePlacements(model, data)
        expected_velocity = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    expected = _tcp(model, q)
    expected_jacobian = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
    state = robot.state(q, v)
    unreferenced = robot.state(q)  # collected before the edit: nothing to re-evaluate
    del unreferenced
    _raise(robot)
    np.testing.assert_allclose(state.frame_placement(fid).translation, expected, atol=1e-12)
    np.testing.assert_allclose(state.frame_jacobian(fid), expected_jacobian, atol=1e-12)
    assert state.has_velocity is velocity
    if velocity:
        np.testing.assert_array_equal(state.v, v)
        np.testing.assert_allclose(state.frame_velocity(fid), expected_velocity.vector, atol=1e-12)


def test_an_armed_step_on_a_state_of_before_the_edit_is_the_fresh_states_step() -> None:
    robot = _fresh()
    q = robot.q_default.copy()
    target = _tcp(robot.model, q) + np.array([0.05, -0.05, 0.15])
    ik = DifferentialIK(
        robot,
        [Task(F.Position(robot, TCP), target)],
        [JointPositionLimits(robot)],
        options=DifferentialIKOptions(native=True),
    )
    old = robot.state(q)
    ik.advance(robot.state(q), 0.01)  # armed before the edit
    _raise(robot)
    first = ik.advance(old, 0.01)  # no update of ``old`` after the edit
    reference = ik.advance(robot.state(q), 0.01)
    np.testing.assert_allclose(first.dq, reference.dq, atol=1e-12)


def test_edit_model_refuses_structure_and_bad_limits_and_leaves_the_robot() -> None:
    robot = _fresh()
    version, nframes = robot.version, robot.model.nframes
    reference = robot.model.copy()
    with pytest.raises(InvalidInputError, match="more than values"), robot.edit_model() as m:
        m.addFrame(pin.Frame("extra", 1, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    with pytest.raises(InvalidInputError, match="lower limits above upper"):
        with robot.edit_model() as m:
            m.lowerPositionLimit[0] = m.upperPositionLimit[0] + 1.0
            m.jointPlacements[1] = _raised(reference).jointPlacements[1]
    with pytest.raises(ZeroDivisionError), robot.edit_model() as m:
        m.jointPlacements[1] = _raised(reference).jointPlacements[1]
        _ = 1 / 0
    assert robot.version == version and robot.model.nframes == nframes
    assert robot.model == reference


def test_edit_model_limits_follow_set_limits_semantics() -> None:
    robot = _fresh()
    lower = robot.lower_limits.copy()
    with robot.edit_model() as m:
        m.lowerPositionLimit[0] = lower[0] + 0.5
    assert robot.lower_limits[0] == lower[0] + 0.5
    limits = JointPositionLimits(robot)
    assert limits.model_version == robot.version


def test_armed_ik_reaches_the_target_of_the_edited_kinematics() -> None:
    robot = _fresh()
    q = robot.q_default.copy()
    target = _tcp(robot.model, q) + np.array([0.05, -0.05, 0.05])
    ik = DifferentialIK(
        robot,
        [Task(F.Position(robot, TCP), target)],
        [JointPositionLimits(robot)],
        options=DifferentialIKOptions(native=True),
    )
    state = robot.state(q)
    for _ in range(3):  # armed before the edit
        ik.advance(state, 0.1)
    _raise(robot)
    # the old arm reaches the target from 0.4 m below: the target, raised, is reachable again
    target_raised = target + np.array([0.0, 0.0, RAISE])
    ik.tasks[0].set_target(target_raised)
    for _ in range(300):
        ik.advance(state, 0.1)
    reached = _tcp(_raised(_fresh().model), state.q)
    np.testing.assert_allclose(reached, target_raised, atol=1e-4)


@pytest.mark.parametrize("native", [True, False])
def test_inverse_dynamics_uses_the_edited_inertias(native: bool) -> None:
    robot = _fresh()
    q = robot.q_default.copy()
    posture = Task(F.JointConfiguration(robot), q, kp=0.0, kd=0.0)
    controller = InverseDynamicsQP(robot, [posture], [], InverseDynamicsOptions(native=native))
    state = robot.state(q, np.zeros(robot.nv))
    controller.solve(state)  # built and solved once before the edit
    heavier = robot.model.copy()
    inertia = heavier.inertias[4]
    heavier.inertias[4] = pin.Inertia(3.0 * inertia.mass, inertia.lever, 3.0 * inertia.inertia)
    with robot.edit_model() as m:
        m.inertias[4] = heavier.inertias[4]
    state = robot.state(q, np.zeros(robot.nv))
    result = controller.solve(state)
    gravity = pin.rnea(heavier, heavier.createData(), q, np.zeros(robot.nv), np.zeros(robot.nv))
    old = pin.rnea(_fresh().model, _fresh().model.createData(), q, *(2 * [np.zeros(robot.nv)]))
    assert np.max(np.abs(gravity - old)) > 1.0  # the edit matters
    np.testing.assert_allclose(result.tau, gravity, atol=1e-5 * np.max(np.abs(gravity)))


# ---------------------------------------------------------------------- collision geometry
@pytest.fixture
def plated() -> tuple[Robot, np.ndarray, np.ndarray, np.ndarray]:
    """Panda, a plate ``RAISE`` above the arc its hand sweeps, and three configurations."""
    robot = _fresh(geometry=True)
    q0 = robot.q_default.copy()
    q1, qm = q0.copy(), q0.copy()
    q1[0] += 1.2
    qm[0] += 0.6
    hand = robot.frame_placement(qm, TCP).translation + np.array([0.0, 0.0, RAISE])
    yaw = float(np.arctan2(hand[1], hand[0]))
    plate = Obstacle.box("plate", [0.3, 0.005, 0.2], pin.SE3(pin.utils.rotate("z", yaw), hand))
    robot.add_obstacle(plate)
    return robot, q0, q1, qm


@pytest.mark.parametrize("native", [True, False])
def test_checker_space_and_planner_follow_edit_model(
    plated: tuple[Robot, np.ndarray, np.ndarray, np.ndarray], native: bool
) -> None:
    robot, q0, q1, qm = plated
    options = CollisionCheckerOptions(native=native)
    checker = CollisionChecker(robot, options)
    space = ConfigurationSpace.from_robot(robot, checker_options=options)
    geom = robot.collision_model
    assert not _collides(robot.model, geom, qm) and checker.is_valid(qm) and space.is_valid(qm)
    raised = _raised(robot.model)
    assert _collides(raised, geom, qm)  # the raised hand meets the plate
    assert not _collides(raised, geom, q0) and not _collides(raised, geom, q1)
    _raise(robot)
    assert not checker.is_valid(qm) and not space.is_valid(qm)
    result = rrt_connect(space, q0, q1, RRTConnectOptions(native=native, seed=3))
    assert result.success
    path = np.asarray(result.path)
    dense = [
        path[i] + t * (path[i + 1] - path[i])
        for i in range(len(path) - 1)
        for t in np.linspace(0.0, 1.0, 40)
    ]
    assert not any(_collides(raised, geom, q) for q in dense)


@pytest.mark.parametrize("native", [True, False])
def test_checker_follows_edit_collision_model(
    plated: tuple[Robot, np.ndarray, np.ndarray, np.ndarray], native: bool
) -> None:
    robot, _, _, qm = plated
    checker = CollisionChecker(robot, CollisionCheckerOptions(native=native))
    assert checker.is_valid(qm)
    shifted = pin.SE3.Identity()
    shifted.translation = np.array([0.0, 0.0, RAISE])
    names = [
        robot.collision_model.geometryObjects[i].name for i in range(robot.robot_geometry_count)
    ]
    moved = [
        n for n in names if n.startswith(("panda_hand", "panda_leftfinger", "panda_rightfinger"))
    ]
    reference = robot.collision_model.copy()
    version = robot.world.version
    with robot.edit_collision_model() as geom:
        for n in moved:  # the hand's geometry lifted in the world frame at qm (joint 0 only)
            obj = geom.geometryObjects[geom.getGeometryId(n)]
            obj.placement = _lift_in_world(robot, qm, obj.parentJoint, obj.placement)
    for n in moved:
        obj = reference.geometryObjects[reference.getGeometryId(n)]
        obj.placement = _lift_in_world(robot, qm, obj.parentJoint, obj.placement)
    assert robot.world.version != version
    assert _collides(robot.model, reference, qm)
    assert not checker.is_valid(qm)
    assert robot.collision_model == reference


def _lift_in_world(robot: Robot, q: np.ndarray, joint: int, placement: pin.SE3) -> pin.SE3:
    """``placement`` (in ``joint``'s frame) moved by ``RAISE`` up in the world frame at ``q``."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    oMj = data.oMi[joint]
    world = oMj * placement
    world.translation = world.translation + np.array([0.0, 0.0, RAISE])
    return oMj.inverse() * world


def test_edit_collision_model_pairs_and_refusals(
    plated: tuple[Robot, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    robot, _, _, _ = plated
    pairs = robot.collision_pairs
    with robot.edit_collision_model() as geom:
        geom.removeCollisionPair(geom.collisionPairs[0])
    assert robot.collision_pairs == pairs[1:]
    version = robot.world.version
    plate = robot.collision_model.getGeometryId("plate")
    with pytest.raises(InvalidInputError, match="obstacle 'plate' changed"):
        with robot.edit_collision_model() as geom:
            geom.geometryObjects[plate].placement = pin.SE3.Identity()
    with pytest.raises(InvalidInputError, match="geometries became"):
        with robot.edit_collision_model() as geom:
            geom.removeGeometryObject("plate")
    assert robot.world.version == version and robot.collision_pairs == pairs[1:]


@pytest.mark.slow  # two sphere models of the panda (3-12 s)
def test_sphere_model_follows_a_shape_replaced_through_the_robot() -> None:
    """The cached spheres of the sphere checker cover a new, larger shape of the hand."""
    import coal

    robot = _fresh(geometry=True)
    checker = CollisionChecker(robot)
    gid = robot.collision_model.getGeometryId("panda_hand_0")
    before = checker.sphere_model()
    radius = 0.12
    with robot.edit_collision_model() as geom:
        geom.geometryObjects[gid].geometry = coal.Sphere(radius)
    spheres = checker.sphere_model()
    assert spheres is not before
    obj = robot.collision_model.geometryObjects[gid]
    mine = spheres.geometries == gid
    # points of the new shape's surface, in the joint frame: each inside one of its spheres
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(200, 3))
    points = radius * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    in_joint = (obj.placement.rotation @ points.T).T + obj.placement.translation
    gaps = np.linalg.norm(in_joint[:, None, :] - spheres.centers[mine][None], axis=2)
    assert np.all(np.min(gaps - spheres.radii[mine][None], axis=1) <= 1e-9)
