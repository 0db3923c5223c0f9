"""RelativeFramePose: Jacobian, residual Jacobian and drift against finite differences, and
its value against Pinocchio's frame placements (issue #16, item 5)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.errors import TaskspaceError
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot
from tests.problems import random_configurations, random_velocity

EPS = 1e-6
CASES = [
    ("panda", "panda_hand_tcp", "panda_link3"),
    ("g1", "left_rubber_hand", "right_ankle_roll_link"),
    ("ur5", "tool0", "shoulder_link"),
]


def _relative(robot: Robot, q: np.ndarray, b: str, a: str) -> pin.SE3:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    T_a = data.oMf[robot.model.getFrameId(a)]
    T_b = data.oMf[robot.model.getFrameId(b)]
    return T_a.inverse() * T_b


def _robot(name: str) -> Robot:
    try:
        return load_robot(name)
    except Exception as exc:  # pragma: no cover - a robot missing from example-robot-data
        pytest.skip(f"{name}: {exc}")


@pytest.mark.parametrize(("name", "frame", "reference"), CASES)
def test_value_jacobian_and_residual_jacobian_match_finite_differences(
    name: str, frame: str, reference: str
) -> None:
    robot = _robot(name)
    feature = F.RelativeFramePose(robot, frame, reference)
    model = robot.model
    for k, q in enumerate(random_configurations(robot, 4, seed=3)):
        state = robot.state(q)
        T0 = _relative(robot, q, frame, reference)
        np.testing.assert_allclose(feature.value(state).homogeneous, T0.homogeneous, atol=1e-12)
        target = T0 * pin.exp6(np.random.default_rng(k).normal(scale=0.3, size=6))
        J = feature.jacobian(state)
        Jr = feature.residual_jacobian(state, target)
        e, Jr2 = feature.residual_and_jacobian(state, target)
        np.testing.assert_allclose(Jr2, Jr, atol=1e-12)
        np.testing.assert_allclose(e, pin.log6(target.inverse() * T0).vector, atol=1e-12)
        J_fd = np.zeros_like(J)
        Jr_fd = np.zeros_like(J)
        for i in range(robot.nv):
            dv = np.zeros(robot.nv)
            dv[i] = EPS
            qp, qm = pin.integrate(model, q, dv), pin.integrate(model, q, -dv)
            Tp, Tm = _relative(robot, qp, frame, reference), _relative(robot, qm, frame, reference)
            J_fd[:, i] = (
                pin.log6(T0.inverse() * Tp).vector - pin.log6(T0.inverse() * Tm).vector
            ) / (2 * EPS)
            Jr_fd[:, i] = (
                pin.log6(target.inverse() * Tp).vector - pin.log6(target.inverse() * Tm).vector
            ) / (2 * EPS)
        scale = max(1.0, float(np.abs(J).max()))
        np.testing.assert_allclose(J, J_fd, atol=1e-7 * scale)
        np.testing.assert_allclose(Jr, Jr_fd, atol=1e-7 * scale)


@pytest.mark.parametrize(("name", "frame", "reference"), CASES)
def test_drift_matches_finite_differences(name: str, frame: str, reference: str) -> None:
    robot = _robot(name)
    feature = F.RelativeFramePose(robot, frame, reference)
    model = robot.model
    for seed, q in enumerate(random_configurations(robot, 3, seed=5)):
        v = random_velocity(robot, seed)
        h = 1e-6
        Jp = feature.jacobian(robot.state(pin.integrate(model, q, h * v)))
        Jm = feature.jacobian(robot.state(pin.integrate(model, q, -h * v)))
        expected = (Jp - Jm).dot(v) / (2 * h)
        drift = feature.drift(robot.state(q, v))
        np.testing.assert_allclose(drift, expected, atol=1e-6 * max(1.0, np.abs(expected).max()))


def test_ik_reaches_a_relative_target() -> None:
    robot = load_robot("panda")
    # joints 2-7 move the hand in link 1: six joints for a 6-D target
    feature = F.RelativeFramePose(robot, "panda_hand_tcp", "panda_link1")
    q = robot.q_default.copy()
    target = feature.value(robot.state(q)) * pin.exp6(np.array([0.03, -0.02, 0.04, 0.1, 0.0, -0.1]))
    task = Task(feature, target)
    ik = DifferentialIK(robot, [task], options=DifferentialIKOptions(damping=1e-9))
    state = robot.state(q)
    for _ in range(30):
        state.update(q)
        q = pin.integrate(robot.model, q, ik.solve(state, 0.01).dq)
    state.update(q)
    assert np.linalg.norm(task.error(state)) < 1e-8
    T = _relative(robot, q, "panda_hand_tcp", "panda_link1")
    np.testing.assert_allclose(T.homogeneous, target.homogeneous, atol=1e-8)


def test_errors_name_the_frames() -> None:
    robot = load_robot("panda")
    with pytest.raises(TaskspaceError, match="panda_hnd"):
        F.RelativeFramePose(robot, "panda_hnd", "panda_link3")
    with pytest.raises(TaskspaceError):
        Task(F.RelativeFramePose(robot, "panda_hand_tcp", "panda_link3"), [1.0, 2.0])
