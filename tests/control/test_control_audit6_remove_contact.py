"""InverseDynamicsQP.remove_contact with extreme transitions or a Contact object, audit6.

Before: ``remove_contact("FL_FOOT", 1e300, dt=1e-300)`` raised a bare OverflowError
("cannot convert float infinity to integer"), and a Contact object instead of its frame name
was "no active contact on frame <...PointContact object at 0x...>". Now the ratio is named,
and a Contact is read as its frame (the transition then runs as for the name: the bound of
the released foot's normal force falls linearly to 0 over the steps).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import PointContact
from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
from taskspace.errors import InvalidInputError
from taskspace.tasks import Task

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


def _controller(robot: Any) -> tuple[InverseDynamicsQP, list[PointContact]]:
    contacts = [PointContact(robot, f) for f in FEET]
    com = pin.centerOfMass(robot.model, robot.model.createData(), robot.q_default)
    tasks = [
        Task(F.CenterOfMass(robot), com, kp=10.0),
        Task(F.JointConfiguration(robot), robot.q_default, kp=10.0, weight=1e-2),
    ]
    return InverseDynamicsQP(robot, tasks, contacts), contacts


def test_a_transition_of_infinitely_many_steps_is_named(robot_loader: Any) -> None:
    ctrl, _ = _controller(robot_loader("solo12"))
    with pytest.raises(InvalidInputError, match="transition_time / dt"):
        ctrl.remove_contact("FL_FOOT", 1e300, dt=1e-300)
    assert ctrl.releasing == {}  # nothing started


def test_a_contact_object_is_read_as_its_frame(robot_loader: Any) -> None:
    robot = robot_loader("solo12")
    ctrl, contacts = _controller(robot)
    state = robot.state(robot.q_default, np.zeros(robot.nv))
    ctrl.solve(state)
    ctrl.remove_contact(contacts[0], 0.03, dt=0.01)  # 3 steps
    bounds = []
    for _ in range(3):
        res = ctrl.solve(state)
        bounds.append(res.releasing["FL_FOOT"])
        assert res.forces["FL_FOOT"][2] <= bounds[-1] + 1e-6
    assert bounds[-1] == 0.0
    np.testing.assert_allclose(np.diff(bounds), bounds[1] - bounds[0], rtol=1e-9)
    ctrl.solve(state)
    assert "FL_FOOT" not in [c.frame for c in ctrl.contacts]
