"""Controllers and simulations given objects of the wrong kind, new-user sweep audit6.

Before: ``simulate(..., options={...})``, ``operational_space_control(..., {...})`` and
``InverseDynamicsQP(options={...})`` raised a bare AttributeError ('dict' object has no
attribute ...), as did InverseDynamicsQP given numbers as tasks or frame names as contacts;
``PIDGains.from_wavelength(1, 1e-200, 1)`` a bare ZeroDivisionError (lambda^2 underflows);
``simulate_with_contacts`` ran with NaN or negative Baumgarte gains (NaN: reported as a
diverged simulation, negative: an unstable contact drift accepted) and with dt > duration
returned one sample; a state of another robot object named like the controller's robot was
refused with the confusing "built for robot 'ur5'; the state belongs to robot 'ur5'".
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import PointContact
from taskspace.control import (
    OperationalSpaceController,
    PIDGains,
    operational_space_control,
)
from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
from taskspace.control.inverse_dynamics_qp_rollout import simulate_with_contacts
from taskspace.dynamics import simulate
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.tasks import Task


@pytest.fixture(scope="module")
def ur5(robot_loader: Any) -> Any:
    return robot_loader("ur5")


def _task(robot: Any) -> Task:
    return Task(F.JointConfiguration(robot), robot.q_default, kp=10.0)


def test_simulate_names_options_of_the_wrong_kind(ur5: Any) -> None:
    with pytest.raises(InvalidInputError, match="SimulationOptions"):
        simulate(ur5, None, (ur5.q_default, np.zeros(6)), 0.01, 1e-3, {"integrator": "rk4"})


def test_operational_space_names_options_of_the_wrong_kind(ur5: Any) -> None:
    state = ur5.state(ur5.q_default, np.zeros(6))
    with pytest.raises(InvalidInputError, match="OperationalSpaceOptions"):
        operational_space_control(state, [_task(ur5)], {"hard_tasks": True})  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="OperationalSpaceOptions"):
        OperationalSpaceController(ur5, [_task(ur5)], {"hard_tasks": True})  # type: ignore[arg-type]


def test_inverse_dynamics_qp_names_arguments_of_the_wrong_kind(ur5: Any) -> None:
    with pytest.raises(InvalidInputError, match="InverseDynamicsOptions"):
        InverseDynamicsQP(ur5, [_task(ur5)], options={"native": False})  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="Task"):
        InverseDynamicsQP(ur5, [1, 2])  # type: ignore[list-item]
    with pytest.raises(InvalidInputError, match="Contact"):
        InverseDynamicsQP(ur5, [_task(ur5)], ["tool0"])  # type: ignore[list-item]


def test_a_state_of_a_namesake_robot_is_named_as_such(ur5: Any) -> None:
    other = Robot.load("ur5", geometry=False)
    ctrl = InverseDynamicsQP(ur5, [_task(ur5)])
    with pytest.raises(InvalidInputError, match="another Robot object"):
        ctrl.solve(other.state(other.q_default, np.zeros(6)))


def test_pid_gains_from_a_tiny_wavelength_are_named() -> None:
    with pytest.raises(InvalidInputError, match="wavelength"):
        PIDGains.from_wavelength(1.0, 1e-200, 1.0)
    with pytest.raises(InvalidInputError, match="wavelength"):
        PIDGains.from_wavelength(1e300, 1e-10, 1.0)
    gains = PIDGains.from_wavelength(2.0, 0.5, 0.7)  # slide 5:14: Kp = m / l^2, Kd = 2 m xi / l
    assert gains.kp == pytest.approx(8.0, rel=1e-15)
    assert gains.kd == pytest.approx(5.6, rel=1e-15)


@pytest.fixture(scope="module")
def solo(robot_loader: Any) -> Any:
    robot = robot_loader("solo12")
    feet = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
    contacts = [PointContact(robot, f) for f in feet]
    com = pin.centerOfMass(robot.model, robot.model.createData(), robot.q_default)
    tasks = [
        Task(F.CenterOfMass(robot), com, kp=10.0),
        Task(F.JointConfiguration(robot), robot.q_default, kp=10.0, weight=1e-2),
    ]
    ctrl = InverseDynamicsQP(robot, tasks, contacts)
    return robot, contacts, lambda t, q, v: ctrl.solve(robot.state(q, v)).tau


@pytest.mark.parametrize("gains", [(float("nan"), 20.0), (0.0, -1.0), (-5.0, 20.0), (0.0, np.inf)])
def test_rollout_refuses_bad_baumgarte_gains(solo: Any, gains: Any) -> None:
    robot, contacts, ctrl = solo
    with pytest.raises(InvalidInputError, match="baumgarte"):
        simulate_with_contacts(
            robot, ctrl, robot.q_default, np.zeros(robot.nv), 0.02, 0.004, contacts, baumgarte=gains
        )


def test_rollout_refuses_a_step_longer_than_the_duration(solo: Any) -> None:
    robot, contacts, ctrl = solo
    with pytest.raises(InvalidInputError, match="dt"):
        simulate_with_contacts(
            robot, ctrl, robot.q_default, np.zeros(robot.nv), 0.01, 0.1, contacts
        )
