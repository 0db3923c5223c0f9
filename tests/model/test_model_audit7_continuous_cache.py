"""Robot.interpolate/difference/distance keep the continuous joints with the model's structure.

The robot finds its continuous joints (their ``(cos, sin)`` pair and angle index) when it
classifies its joints (construction, :meth:`Robot.set_limits`), not with a loop over the joints
at every call. Answers are checked against Pinocchio's ``interpolate``/``difference`` on
normalized configurations away from opposite angles, on kinova (three continuous joints)
and on robots whose models differ: a continuous joint locked (``pin.buildReducedModel``, the
later joints shift in ``q``), a robot built in code with planar, spherical and continuous
joints, used alternately so that no answer comes from another robot's model.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import taskspace.model.robot as robot_module
from taskspace.model import Robot
from taskspace.model.robot import continuous_joint_indices


@pytest.fixture(scope="module")
def kinova() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("kinova")


def _locked(robot: Robot, joint: str) -> Robot:
    """``robot`` with ``joint`` locked at its default posture (a new, reduced model)."""
    model = pin.buildReducedModel(robot.model, [robot.joint_id(joint)], robot.q_default)
    empty = pin.GeometryModel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its default posture (neutral) is clipped into limits
        return Robot(model, empty, empty.copy(), name=f"{robot.name}_locked")


def _mixed() -> Robot:
    """Planar base, continuous (RUBZ), revolute, spherical and unaligned continuous joints."""
    model = pin.Model()
    inertia = pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3)
    parent = 0
    for name, joint in (
        ("base", pin.JointModelPlanar()),
        ("wheel", pin.JointModelRUBZ()),
        ("elbow", pin.JointModelRY()),
        ("wrist", pin.JointModelSpherical()),
        ("spin", pin.JointModelRevoluteUnboundedUnaligned()),
    ):
        lo = np.full(joint.nq, -1.0 if name == "elbow" else -np.inf)
        hi = np.full(joint.nq, 1.0 if name == "elbow" else np.inf)
        placement = pin.SE3(np.eye(3), np.array([0.2, 0.0, 0.1]))
        parent = model.addJoint(
            parent, joint, placement, name, np.ones(joint.nv), np.ones(joint.nv), lo, hi
        )
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    empty = pin.GeometryModel()
    return Robot(model, empty, empty.copy(), name="mixed")


def _check_against_pinocchio(robot: Robot, rng: np.random.Generator) -> None:
    model = robot.model
    for _ in range(20):
        a = robot.random_configuration(rng)
        b = robot.random_configuration(rng)
        c, _v = continuous_joint_indices(model)
        # away from opposite angles, where pin.interpolate stays at q0 (documented)
        dots = a[c] * b[c] + a[c + 1] * b[c + 1]
        if np.any(dots < -0.99):
            continue
        expected = np.asarray(pin.difference(model, a, b))
        np.testing.assert_allclose(robot.difference(a, b), expected, atol=1e-12)
        assert robot.distance(a, b) == pytest.approx(float(np.linalg.norm(expected)), abs=1e-12)
        for t in (0.0, 0.3, 1.0):
            np.testing.assert_allclose(
                robot.interpolate(a, b, t), pin.interpolate(model, a, b, t), atol=1e-12
            )


def test_answers_match_pinocchio_on_robots_with_different_models(kinova: Robot) -> None:
    locked = _locked(kinova, "j2s6s200_joint_2")
    locked_continuous = _locked(kinova, "j2s6s200_joint_1")
    mixed = _mixed()
    rng = np.random.default_rng(3)
    for robot in (kinova, locked, locked_continuous, mixed, kinova, locked_continuous):
        _check_against_pinocchio(robot, rng)
    # locking the first continuous joint shifts the others in q and v
    c_full, _ = continuous_joint_indices(kinova.model)
    c_locked, _ = continuous_joint_indices(locked_continuous.model)
    assert c_full.size == 3 and c_locked.size == 2
    assert not np.array_equal(c_full[1:], c_locked)


def test_no_joint_loop_per_call(kinova: Robot, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(5)
    a = kinova.random_configuration(rng)
    b = kinova.random_configuration(rng)
    before = (kinova.interpolate(a, b, 0.4), kinova.difference(a, b), kinova.distance(a, b))

    def refuse(model: pin.Model) -> None:
        raise AssertionError("continuous joints searched again at a call")

    monkeypatch.setattr(robot_module, "continuous_joint_indices", refuse)
    after = (kinova.interpolate(a, b, 0.4), kinova.difference(a, b), kinova.distance(a, b))
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])
    assert before[2] == after[2]


def test_model_changes_keep_the_answers_of_the_changed_model(kinova: Robot) -> None:
    robot = _locked(kinova, "j2s6s200_joint_2")  # a robot of its own: its model changes here
    rng = np.random.default_rng(11)
    version = robot.version
    lower = robot.lower_limits.copy()
    upper = robot.upper_limits.copy()
    idx = robot.limited_joints_q
    lower[idx] += 0.1
    upper[idx] -= 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the default posture is clipped into the new limits
        robot.set_limits(lower=lower, upper=upper)
    with robot.edit_model() as model:
        model.jointPlacements[2] = pin.SE3(np.eye(3), np.array([0.0, 0.1, 0.3]))
    assert robot.version != version
    c, v = robot._continuous
    expected_c, expected_v = continuous_joint_indices(robot.model)
    np.testing.assert_array_equal(c, expected_c)
    np.testing.assert_array_equal(v, expected_v)
    _check_against_pinocchio(robot, rng)
    # the opposite-angle case stays the robot's own: the joint turns by pi
    a = robot.neutral()
    b = a.copy()
    b[expected_c[0] : expected_c[0] + 2] = (-1.0, 0.0)
    assert abs(robot.difference(a, b)[expected_v[0]]) == pytest.approx(np.pi)
    mid = robot.interpolate(a, b, 0.5)
    np.testing.assert_allclose(mid[expected_c[0] : expected_c[0] + 2], (0.0, 1.0), atol=1e-12)
