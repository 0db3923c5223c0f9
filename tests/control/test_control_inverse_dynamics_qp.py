"""Inverse-dynamics QP (operational-space control with contacts, torque and joint limits)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import InvalidInputError
from taskspace import features as F
from taskspace.constraints import Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import (
    InverseDynamicsOptions,
    InverseDynamicsQP,
    InverseDynamicsStatus,
)
from taskspace.control.inverse_dynamics_qp_rollout import simulate_with_contacts
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot

G1_FEET = ["left_ankle_roll_link", "right_ankle_roll_link"]
G1_HANDS = ["left_rubber_hand", "right_rubber_hand"]


def g1_controller(robot: Robot, hierarchical: bool = False):  # type: ignore[no-untyped-def]
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in G1_FEET]
    com = Task(F.CenterOfMass(robot), kp=50.0, priority=0)
    com.set_target_from_state(s)
    hands = [Task(F.FramePose(robot, h), kp=50.0, weight=0.1, priority=1) for h in G1_HANDS]
    for t in hands:
        t.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    options = InverseDynamicsOptions(hierarchical=hierarchical)
    return InverseDynamicsQP(robot, [com, *hands, posture], contacts, options), com, hands, s


def dynamics_terms(robot: Robot, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data = robot.model.createData()
    M = pin.crba(robot.model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    return M, pin.nonLinearEffects(robot.model, data, q, v)


@pytest.mark.parametrize("hierarchical", [False, True])
def test_solution_satisfies_the_equations_of_motion(hierarchical: bool) -> None:
    robot = load_robot("g1")
    ctrl, _, _, s = g1_controller(robot, hierarchical)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = robot.q_default.copy()
        q[7:] += rng.normal(scale=0.05, size=robot.nq - 7)
        v = rng.normal(scale=0.2, size=robot.nv)
        s.update(q, v)
        res = ctrl.solve(s)
        assert res.success, res.status
        M, h = dynamics_terms(robot, q, v)
        Jc = np.vstack([c.jacobian(s) for c in ctrl.contacts])
        f = np.concatenate([res.forces[n] for n in G1_FEET])
        # M a + h = S^T tau + J_c^T f, with zero torque on the floating base
        np.testing.assert_allclose(M @ res.a + h, res.tau + Jc.T @ f, atol=1e-7)
        assert np.all(res.tau[:6] == 0.0)
        # rigid contacts: J_c a + Jdot_c v = -kd J_c v
        for c in ctrl.contacts:
            lhs = c.jacobian(s) @ res.a + s.frame_drift_local(c.frame_id)
            np.testing.assert_allclose(lhs, -c.kd * (c.jacobian(s) @ v), atol=1e-6)


def test_forces_stay_in_the_friction_cone_and_torques_in_limits() -> None:
    robot = load_robot("g1")
    ctrl, com, _, s = g1_controller(robot)
    # an aggressive sideways CoM target: the unconstrained solution would pull on a foot
    com.set_target(com.target + np.array([0.0, 0.5, 0.0]))
    com.kp = 2000.0
    com.kd = 90.0
    res = ctrl.solve(s)
    assert res.success
    for c in ctrl.contacts:
        K, k = c.cone()
        assert np.all(K @ res.forces[c.frame] >= k - 1e-7)
    limits = robot.effort_limits
    assert np.all(np.abs(res.tau) <= limits + 1e-6)


def test_torque_limits_bind_on_the_panda() -> None:
    robot = load_robot("panda")
    s = robot.state(robot.q_default, np.zeros(7))
    tcp = Task(F.Position(robot, "panda_hand_tcp"), kp=1e5, kd=600.0)
    tcp_position = s.frame_placement(robot.frame_id("panda_hand_tcp")).translation
    target = tcp_position + np.array([0.3, 0.3, -0.3])
    tcp.set_target(target)
    free = InverseDynamicsQP(robot, [tcp], options=InverseDynamicsOptions(torque_limits=False))
    limited = InverseDynamicsQP(robot, [tcp])
    tau_free = free.solve(s).tau
    res = limited.solve(s)
    assert np.any(np.abs(tau_free) > robot.effort_limits)  # the limits matter here
    assert res.success and np.all(np.abs(res.tau) <= robot.effort_limits + 1e-6)


def test_unconstrained_case_equals_operational_space_least_squares() -> None:
    """Without active constraints: a = argmin |J a + Jdot v - y''*|^2 + lambda |a|^2."""
    robot = load_robot("panda")
    rng = np.random.default_rng(3)
    q = robot.q_default + rng.normal(scale=0.1, size=7)
    v = rng.normal(scale=0.3, size=7)
    s = robot.state(q, v)
    task = Task(F.FramePose(robot, "panda_hand_tcp"), kp=10.0)
    task.set_target(
        s.frame_placement(robot.frame_id("panda_hand_tcp"))
        * pin.SE3(np.eye(3), np.array([0.01, 0.0, 0.01]))
    )
    options = InverseDynamicsOptions(torque_limits=False, joint_limits=False)
    res = InverseDynamicsQP(robot, [task], options=options).solve(s)
    e, J = task.feature.residual_and_jacobian(s, task.target)
    desired = -task.kp * e - task.kd * (J @ v) - task.feature.drift(s)
    lam = options.acceleration_regularization
    expected = np.linalg.solve(J.T @ J + lam * np.eye(7), J.T @ desired)
    np.testing.assert_allclose(res.a, expected, atol=1e-8)
    M, h = dynamics_terms(robot, q, v)
    np.testing.assert_allclose(res.tau, M @ expected + h, atol=1e-6)


def test_quadruped_point_contacts() -> None:
    robot = load_robot("solo12")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]
    contacts = [PointContact(robot, f, friction=0.6) for f in feet]
    base = Task(F.FramePose(robot, "base_link"), kp=100.0)
    base.set_target_from_state(s)
    ctrl = InverseDynamicsQP(robot, [base], contacts)
    res = ctrl.solve(s)
    assert res.success
    total = sum(res.forces[f][2] for f in feet)
    # standing still: the feet carry exactly the weight
    assert total == pytest.approx(robot.mass * 9.81, rel=1e-4)
    for c in contacts:
        K, k = c.cone()
        assert np.all(K @ res.forces[c.frame] >= k - 1e-7)


@pytest.mark.slow
def test_humanoid_does_not_fall_over_5_seconds() -> None:
    robot = load_robot("g1")
    ctrl, com, _, s = g1_controller(robot)
    c0 = com.target.copy()

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        com.set_target(c0 + np.array([0.0, 0.04 * np.sin(np.pi * t), 0.0]))
        s.update(q, v)
        res = ctrl.solve(s)
        assert res.success
        return res.tau

    roll = simulate_with_contacts(
        robot, controller, robot.q_default, np.zeros(robot.nv), 5.0, 0.005, G1_FEET
    )
    # the CoM stays at its height and sways sideways as asked
    assert np.ptp(roll.com[:, 2]) < 0.01
    assert roll.com[:, 1].max() > c0[1] + 0.015 and roll.com[:, 1].min() < c0[1] - 0.015
    for name, wrench in roll.forces.items():
        contact = next(c for c in ctrl.contacts if c.frame == name)
        K, k = contact.cone()
        slack = (wrench @ K.T - k).min()
        assert slack > -1e-3, f"{name} leaves its friction cone / CoP area by {slack}"
    assert np.all(np.abs(roll.tau) <= robot.effort_limits + 1e-6)


def test_hierarchy_keeps_the_higher_priority() -> None:
    robot = load_robot("g1")
    ctrl, com, hands, s = g1_controller(robot, hierarchical=True)
    # conflicting hand targets far away: the CoM (priority 0) must not give way
    for h in hands:
        h.set_target(h.target * pin.SE3(np.eye(3), np.array([0.6, 0.0, 0.5])))
    res = ctrl.solve(s)
    assert res.success
    J, rhs = com.acceleration_rows(s)
    # held to the QP tolerance (daqp, 1e-9 regularization) while the hands miss by > 1 m/s^2
    np.testing.assert_allclose(J @ res.a, rhs, atol=1e-4)
    assert res.residuals[1] > 1.0  # the hands do not get what they ask


def test_errors() -> None:
    robot = load_robot("panda")
    task = Task(F.Position(robot, "panda_hand_tcp"), [0.3, 0.0, 0.5])
    ctrl = InverseDynamicsQP(robot, [task])
    with pytest.raises(InvalidInputError, match="inverse dynamics needs the velocity"):
        ctrl.solve(robot.state())
    with pytest.raises(InvalidInputError, match="needs at least one task"):
        InverseDynamicsQP(robot, [])
    other = Task(F.Position(load_robot("ur5"), "tool0"), [0.3, 0.0, 0.5])
    with pytest.raises(InvalidInputError, match="task 'position\\(tool0\\)' is defined on another"):
        InverseDynamicsQP(robot, [other])
    assert InverseDynamicsStatus.SOLVED.value == "solved"
