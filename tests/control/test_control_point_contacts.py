"""Point contacts (3-D force, friction cone, no moment) in the inverse-dynamics QP and rollout.

Solo-12 stands on its four point feet for 2 s in Pinocchio's constraint dynamics (3-D rigid
contacts, free to rotate), the simulated forces checked against the cones at every step.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
from taskspace.control.inverse_dynamics_qp_rollout import (
    ContactViolationError,
    simulate_with_contacts,
)
from taskspace.errors import InvalidInputError
from taskspace.tasks import Task
from tests.conftest import load_robot

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


def solo_controller() -> tuple[object, InverseDynamicsQP, list[PointContact], Task]:
    robot = load_robot("solo12")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [PointContact(robot, f, friction=0.6) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=10.0)
    return s, InverseDynamicsQP(robot, [com, posture], contacts), contacts, com


def test_solo12_stands_two_seconds_on_point_feet() -> None:
    robot = load_robot("solo12")
    s, ctrl, contacts, com = solo_controller()
    c0 = com.target.copy()
    qp_forces: list[np.ndarray] = []

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        s.update(q, v)
        res = ctrl.solve(s)
        assert res.success, res.status
        qp_forces.append(np.concatenate([res.forces[f] for f in FEET]))
        return res.tau

    roll = simulate_with_contacts(
        robot, controller, robot.q_default, np.zeros(robot.nv), 2.0, 0.004, contacts
    )
    assert roll.inside_cones, roll.cone_violations
    assert set(roll.cone_violations) == set(FEET)
    for name in FEET:
        assert roll.forces[name].shape == (roll.t.size, 3)  # 3-D: no moment
    # the simulated forces carry the weight and agree with the QP's (same convention: world)
    weight = pin.computeTotalMass(robot.model) * 9.81
    total = sum(roll.forces[f][:, 2] for f in FEET)
    np.testing.assert_allclose(total, weight, rtol=1e-3)
    sim = np.hstack([roll.forces[f] for f in FEET])
    np.testing.assert_allclose(sim, np.array(qp_forces), atol=1e-3 * weight)
    assert np.linalg.norm(roll.com - c0, axis=1).max() < 1e-3
    # every QP force inside the cone the QP was given
    for i, c in enumerate(contacts):
        K, k = c.cone()
        assert (np.array(qp_forces)[:, 3 * i : 3 * i + 3] @ K.T - k).min() > -1e-7


def test_point_feet_rotate_freely_six_d_feet_do_not() -> None:
    """A point contact transmits no moment: a limp robot's shanks rotate about the feet."""
    robot = load_robot("solo12")
    q0 = robot.q_default

    def limp(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.zeros(robot.nv)

    def foot_rotation(contacts: list) -> float:  # type: ignore[type-arg]
        roll = simulate_with_contacts(robot, limp, q0, np.zeros(robot.nv), 0.1, 0.002, contacts)
        R0 = robot.frame_placement(roll.q[0], "FL_FOOT").rotation
        R1 = robot.frame_placement(roll.q[-1], "FL_FOOT").rotation
        return float(np.linalg.norm(pin.log3(R0.T @ R1)))

    point = [PointContact(robot, f) for f in FEET]
    assert foot_rotation(point) > 1e-3
    assert foot_rotation(list(FEET)) < 1e-6  # 6-D contacts weld the feet


def test_cone_violations_are_reported_or_raised() -> None:
    """Torques that lift the front feet pull on the ground: outside the cone."""
    robot = load_robot("solo12")
    contacts = [PointContact(robot, f) for f in FEET]

    def lift(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        tau = np.zeros(robot.nv)
        tau[6:] = 3.0 * np.sign(np.arange(12) - 5.5)  # strong torques on every joint
        return tau

    roll = simulate_with_contacts(
        robot, lift, robot.q_default, np.zeros(robot.nv), 0.05, 0.002, contacts
    )
    assert not roll.inside_cones
    assert max(roll.cone_violations.values()) > 1e-3
    with pytest.raises(ContactViolationError, match="left its friction cone") as info:
        simulate_with_contacts(
            robot,
            lift,
            robot.q_default,
            np.zeros(robot.nv),
            0.05,
            0.002,
            contacts,
            raise_on_violation=True,
        )
    assert info.value.contact in FEET
    assert info.value.rollout.t[-1] == pytest.approx(info.value.time)


def test_mixed_and_bad_contact_arguments() -> None:
    robot = load_robot("solo12")
    limp = lambda t, q, v: np.zeros(robot.nv)  # noqa: E731
    mixed = [PointContact(robot, "FL_FOOT"), Contact6D(robot, "FR_FOOT"), "HL_FOOT"]
    roll = simulate_with_contacts(
        robot, limp, robot.q_default, np.zeros(robot.nv), 0.01, 0.005, mixed
    )
    assert roll.forces["FL_FOOT"].shape[1] == 3
    assert roll.forces["FR_FOOT"].shape[1] == 6
    assert set(roll.cone_violations) == {"FL_FOOT", "FR_FOOT"}  # names are not checked
    with pytest.raises(InvalidInputError, match=r"frame names .* or Contact objects"):
        simulate_with_contacts(robot, limp, robot.q_default, np.zeros(robot.nv), 0.01, 0.005, [3])
    with pytest.raises(InvalidInputError, match="held by two contacts"):
        simulate_with_contacts(
            robot, limp, robot.q_default, np.zeros(robot.nv), 0.01, 0.005, ["FL_FOOT", "FL_FOOT"]
        )
    other = load_robot("ur5")
    with pytest.raises(InvalidInputError, match="another robot"):
        simulate_with_contacts(
            robot,
            limp,
            robot.q_default,
            np.zeros(robot.nv),
            0.01,
            0.005,
            [PointContact(other, "tool0")],
        )
