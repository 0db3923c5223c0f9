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
from taskspace.errors import TaskspaceError
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
    with pytest.raises(TaskspaceError, match="weighted mode"):
        InverseDynamicsQP(
            robot,
            [com],
            [contact],
            InverseDynamicsOptions(hierarchical=True),
            pressure_tasks=[task],
        )
