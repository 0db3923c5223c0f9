"""Full-torque controllers on a robot with a passive joint, new-user sweep audit6.

The cart-pole's hinge is passive (``passive_joints = ('hinge',)``, effort limit 0). Before:
ComputedTorqueController, JointPDController and operational_space_control returned a torque
on the hinge (computed torque "tracked" a pole angle of 0.3 rad in simulation with 3.25 N m on
a joint that has no motor), and ``linearize(cartpole, q)`` put the hinge among the inputs by
default, so an LQR designed on it used the missing motor. Now the three controllers refuse a
robot with passive joints (they need every joint actuated) and ``linearize`` takes the robot's
actuated joints by default. Reference for B: Pinocchio's crba, ``B = [0; M^-1 S^T]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.control import (
    ComputedTorqueController,
    JointPDController,
    OperationalSpaceController,
    linearize,
    operational_space_control,
)
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.tasks import Task


@pytest.fixture(scope="module")
def cartpole(robot_loader: Any) -> Any:
    robot = robot_loader("cartpole")
    assert robot.passive_joints == ("hinge",)
    return robot


@pytest.mark.parametrize("cls", [ComputedTorqueController, JointPDController])
def test_joint_space_controllers_refuse_a_passive_joint(cartpole: Any, cls: type) -> None:
    with pytest.raises(InvalidInputError, match="hinge"):
        cls(cartpole, np.array([0.5, 0.3]))


def test_operational_space_refuses_a_passive_joint(cartpole: Any) -> None:
    task = Task(F.JointConfiguration(cartpole), np.array([0.5, 0.3]), kp=10.0)
    with pytest.raises(InvalidInputError, match="hinge"):
        operational_space_control(cartpole.state(np.zeros(2), np.zeros(2)), [task])
    with pytest.raises(InvalidInputError, match="hinge"):
        OperationalSpaceController(cartpole, [task])


def test_linearize_takes_the_actuated_joints_by_default(cartpole: Any) -> None:
    q = np.array([0.0, np.pi])  # pole up: an equilibrium with zero torque
    system = linearize(cartpole, q)
    np.testing.assert_array_equal(system.actuated, [0])
    M = pin.crba(cartpole.model, cartpole.model.createData(), q)
    M = np.triu(M) + np.triu(M, 1).T
    expected = np.vstack([np.zeros((2, 1)), np.linalg.inv(M)[:, [0]]])
    np.testing.assert_allclose(system.B, expected, rtol=1e-12, atol=1e-12)
    assert system.tau_eq[1] == 0.0  # nothing asked of the hinge
    # naming the hinge stays possible (the uncontrollable design of the lecture)
    assert linearize(cartpole, q, actuated="hinge").B.shape == (4, 1)


def test_linearize_of_a_robot_without_actuated_joint_names_the_choice() -> None:
    passive = Robot.load("cartpole", geometry=False)  # its own copy: limits edited below
    passive.set_limits(effort=np.zeros(2))
    with pytest.raises(InvalidInputError, match="actuated"):
        linearize(passive, np.zeros(2))
