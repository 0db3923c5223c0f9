"""Tasks of weight 0 in the compiled inverse-dynamics step (kept in a controller while unused).

The kernel leaves them out (their rows are scaled by 0) and takes them in again when their
weight is raised. References: a controller built without those tasks (the same QP), and the
Python path's QP (``native=False``), solved at the same states; Pinocchio's RNEA for the torques.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import InvalidInputError
from taskspace.tasks import Task

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")


def _controller(robot, with_feet: bool, native: bool = True):  # type: ignore[no-untyped-def]
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, FEET[1], half_length=0.1, half_width=0.03)]
    com = Task(F.CenterOfMass(robot), kp=40.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    tasks = [com, posture]
    feet = []
    if with_feet:
        feet = [Task(F.Position(robot, FEET[0]), weight=0.0, kp=400.0)]
        feet.append(Task(F.Orientation(robot, FEET[0]), weight=0.0, kp=400.0))
        for t in feet:
            t.set_target_from_state(s)
        tasks += feet
    options = InverseDynamicsOptions(native=native)
    return s, InverseDynamicsQP(robot, tasks, contacts, options), feet


def test_zero_weight_tasks_change_nothing_and_come_back(robot_loader):
    robot = robot_loader("g1")
    s, ctrl, feet = _controller(robot, True)
    _, plain, _ = _controller(robot, False)
    _, python, python_feet = _controller(robot, True, native=False)
    assert not ctrl.native_reason
    rng = np.random.default_rng(0)
    for k in range(6):
        q = robot.q_default.copy()
        q[7:] += 0.02 * rng.standard_normal(robot.nv - 6)
        s.update(q, 0.1 * rng.standard_normal(robot.nv))
        res = ctrl.solve(s)
        assert res.compiled and res.success
        if k < 3:  # weight 0: the answer of the controller without the tasks
            ref = plain.solve(s)
        else:  # raised: the Python path's answer with the tasks
            ref = python.solve(s)
            assert ref.success
        np.testing.assert_allclose(res.a, ref.a, atol=1e-7)
        np.testing.assert_allclose(res.tau, ref.tau, atol=1e-6)
        rhs = pin.rnea(robot.model, robot.model.createData(), s.q, s.v, res.a)
        data = robot.model.createData()
        pin.computeJointJacobians(robot.model, data, s.q)
        pin.updateFramePlacements(robot.model, data)
        J = pin.getFrameJacobian(robot.model, data, robot.frame_id(FEET[1]), pin.LOCAL)
        rhs -= J.T @ res.forces[FEET[1]]
        np.testing.assert_allclose(res.tau[6:], rhs[6:], atol=1e-6 * np.abs(rhs).max())
        if k == 2:  # the swing foot's tasks come in: same weights on the Python path
            for t, p in zip(feet, python_feet):
                t.weight = p.weight = 1.0
            target = s.frame_placement(robot.frame_id(FEET[0])).translation + np.array([0, 0, 0.02])
            feet[0].set_target(target)
            python_feet[0].set_target(target)


def test_a_zero_weight_task_still_needs_its_target(robot_loader):
    robot = robot_loader("g1")
    s, ctrl, feet = _controller(robot, True)
    feet[1]._target = None  # as a task made without a target
    with pytest.raises(InvalidInputError, match="no target"):
        ctrl.solve(s)
