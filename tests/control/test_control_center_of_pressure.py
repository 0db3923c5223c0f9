"""Center-of-pressure tasks in InverseDynamicsQP (issue #16, item 5)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import (
    CenterOfPressureTask,
    InverseDynamicsOptions,
    InverseDynamicsQP,
)
from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.tasks import Task
from tests.conftest import load_robot

FEET = ["left_ankle_roll_link", "right_ankle_roll_link"]


def _setup(weight: float, target: tuple[float, float]):  # type: ignore[no-untyped-def]
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    cop = CenterOfPressureTask(contacts[0], target, weight=weight)
    ctrl = InverseDynamicsQP(robot, [com, posture], contacts, pressure_tasks=[cop])
    return robot, s, ctrl, cop


def _cop(f: np.ndarray) -> np.ndarray:
    return np.array([-f[4] / f[2], f[3] / f[2]])


def test_center_of_pressure_reaches_its_target() -> None:
    target = (0.04, -0.015)
    robot, s, ctrl, cop = _setup(1e4, target)
    res = ctrl.solve(s)
    assert res.success and res.qp is not None
    assert res.qp.kkt.within(1e-9, 1e-6), res.qp.kkt
    f = res.forces[FEET[0]]
    np.testing.assert_allclose(_cop(f), target, atol=1e-3)
    # without the task the CoP is elsewhere (the test can fail)
    cop.weight = 0.0
    f0 = ctrl.solve(s).forces[FEET[0]]
    assert np.abs(_cop(f0) - target).max() > 5e-3
    # the Hessian's force block: regularization + w R^T R / (m g)^2 (independent assembly)
    cop.weight = 2.0
    p = ctrl.build(s)
    mg = pin.computeTotalMass(robot.model) * 9.81
    R = np.array([[0, 0, 0.015, 1, 0, 0], [0, 0, 0.04, 0, 1, 0]], dtype=float)
    w = Contact6D(robot, FEET[0], half_length=0.1, half_width=0.03).regularization_weights()
    expected = np.diag(1e-2 * w / mg**2) + 2.0 * R.T @ R / mg**2
    nv = robot.nv
    np.testing.assert_allclose(p.H[nv : nv + 6, nv : nv + 6], expected, rtol=1e-3, atol=1e-16)


def test_errors() -> None:
    robot = load_robot("g1")
    contact = Contact6D(robot, FEET[0])
    with pytest.raises(TaskspaceError, match="Contact6D"):
        CenterOfPressureTask(PointContact(robot, FEET[0]))  # type: ignore[arg-type]
    task = CenterOfPressureTask(contact)
    with pytest.raises(TaskspaceError, match="weight"):
        task.weight = float("nan")
    with pytest.raises(TaskspaceError, match="target"):
        task.target = [0.0, np.inf]
    with pytest.raises(TaskspaceError):
        task.target = [0.0, 0.0, 0.0]
    com = Task(F.CenterOfMass(robot))
    with pytest.raises(TaskspaceError, match="not one of"):
        InverseDynamicsQP(robot, [com], [Contact6D(robot, FEET[1])], pressure_tasks=[task])
    for bad in (-1, 1.5, "x", None):
        with pytest.raises(TaskspaceError, match="priority"):
            task.priority = bad  # type: ignore[assignment]
    assert task.priority == 0


def _hierarchy(cop_priority: int | None, target=(0.03, 0.01)):  # type: ignore[no-untyped-def]
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=10.0, priority=0)
    com.set_target_from_state(s)
    com.set_target(com.target + np.array([0.01, -0.005, 0.0]))
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    cops = []
    if cop_priority is not None:
        cops = [CenterOfPressureTask(contacts[0], target, priority=cop_priority)]
    options = InverseDynamicsOptions(hierarchical=True)
    ctrl = InverseDynamicsQP(robot, [com, posture], contacts, options, pressure_tasks=cops)
    return robot, s, ctrl


@pytest.mark.parametrize("priority", [0, 1])
def test_center_of_pressure_task_in_a_strict_hierarchy(priority: int) -> None:
    """Hierarchical mode: the CoP task's rows join the level of its priority. Below the CoM
    task it leaves the CoM level's outcome as without it (strict priority) and reaches its
    target exactly (the analytic CoP of the returned wrench); the torques are Pinocchio's
    RNEA with the contact forces."""
    target = (0.03, 0.01)
    robot, s, ctrl = _hierarchy(priority, target)
    res = ctrl.solve(s)
    assert res.success, res.status
    for lr in res.level_results:
        assert lr.kkt.within(1e-9, 1e-6), lr.kkt
    f = res.forces[FEET[0]]
    np.testing.assert_allclose(_cop(f), target, atol=1e-7)
    model, data = robot.model, robot.model.createData()
    rhs = pin.rnea(model, data, s.q, s.v, res.a)
    pin.computeJointJacobians(model, data, s.q)
    pin.updateFramePlacements(model, data)
    for frame, wrench in res.forces.items():
        rhs -= pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL).T @ wrench
    np.testing.assert_allclose(rhs[:6], 0.0, atol=1e-6)
    np.testing.assert_allclose(res.tau[6:], rhs[6:], atol=1e-6)
    # without the task the CoP is elsewhere; the CoM level's residual is the same when the CoP
    # task is below it
    _, _, plain = _hierarchy(None)
    base = plain.solve(s)
    assert np.abs(_cop(base.forces[FEET[0]]) - target).max() > 5e-3
    if priority == 1:
        assert res.residuals[0] == pytest.approx(base.residuals[0], abs=1e-9)
        assert len(res.level_results) == len(base.level_results) + 1


def test_target_outside_the_sole_is_refused() -> None:
    # a center of pressure lies on the sole (audit6: a 1 m target on a 0.1 m sole was taken)
    robot = load_robot("talos")
    contact = Contact6D(robot, "left_sole_link", half_length=0.1, half_width=0.05)
    task = CenterOfPressureTask(contact, (0.1, -0.05))  # a corner: on the sole
    with pytest.raises(InvalidInputError, match="outside the sole"):
        CenterOfPressureTask(contact, (1.0, 0.0))
    with pytest.raises(InvalidInputError, match="outside the sole"):
        task.target = (0.0, 0.051)
    assert task.target.tolist() == [0.1, -0.05]
