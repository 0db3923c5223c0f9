"""Acceleration-level quality: a standing G1 holds its CoM like TSID with the same gains.

The scene of issue 16: G1 on two 6-D foot contacts, a CoM task with ``kp = 10`` (critically
damped), a posture task, the default options; simulated by Pinocchio's constraint dynamics for
3 s. TSID with these gains holds the CoM within 0.2 mm; the default force regularization
must not pull the CoM away (it drifted 32 mm when it was an absolute 1e-5 / N^2).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.control.inverse_dynamics_qp_rollout import simulate_with_contacts
from taskspace.tasks import Task
from tests.conftest import load_robot

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")


def standing_com_error(options: InverseDynamicsOptions, duration: float) -> float:
    """Largest CoM distance from its start over the rollout [m]."""
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=10.0)
    ctrl = InverseDynamicsQP(robot, [com, posture], contacts, options)
    c0 = com.target.copy()

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        s.update(q, v)
        res = ctrl.solve(s)
        assert res.success, res.status
        assert res.qp is not None and res.qp.kkt.within(1e-9, 1e-9), res.qp.kkt
        return res.tau

    roll = simulate_with_contacts(
        robot, controller, robot.q_default, np.zeros(robot.nv), duration, 0.004, FEET
    )
    # the simulated feet carry the weight inside their cones
    for name, wrench in roll.forces.items():
        K, k = next(c for c in contacts if c.frame == name).cone()
        assert (wrench @ K.T - k).min() > -1e-6
    total = sum(w[:, 2].mean() for w in roll.forces.values())
    weight = pin.computeTotalMass(robot.model) * 9.81
    assert abs(total - weight) < 1e-3 * weight
    return float(np.linalg.norm(roll.com - c0, axis=1).max())


def test_standing_g1_holds_its_com_within_a_millimetre() -> None:
    assert standing_com_error(InverseDynamicsOptions(), 3.0) < 1e-3


def test_a_heavy_force_regularization_would_drift() -> None:
    """The check can fail: the former absolute default 1e-5 / N^2 (about 1.07 relative on G1)."""
    robot = load_robot("g1")
    weight = pin.computeTotalMass(robot.model) * 9.81
    heavy = InverseDynamicsOptions(force_regularization=1e-5 * weight**2)
    assert standing_com_error(heavy, 0.5) > 1e-3
