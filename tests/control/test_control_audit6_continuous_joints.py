"""Joint-space controllers on robots with continuous joints (nq != nv), new-user sweep audit6.

Before: ComputedTorqueController and JointPDController built a fixed target as a reference
whose velocity and acceleration had nq entries, so on any robot with a continuous joint
(kinova: nq = 9, nv = 6; double_pendulum_continuous: nq = 4, nv = 2; tiago) every call raised
numpy's bare "operands could not be broadcast" ValueError; a callable reference with the wrong
sizes did the same. References: Pinocchio's rnea,
computeGeneralizedGravity and difference, and the closed form of the error dynamics
``e'' + kd e' + kp e = 0`` (critically damped: ``e(t) = (e0 + (e0' + w e0) t) exp(-w t)``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import ComputedTorqueController, JointPDController, ReferencePoint
from taskspace.dynamics import SimulationOptions, simulate
from taskspace.errors import InvalidInputError, ShapeError


@pytest.fixture(scope="module")
def kinova(robot_loader: Any) -> Any:
    return robot_loader("kinova")


def _config(robot: Any, angles: Any) -> Any:
    return pin.integrate(robot.model, robot.q_default, np.asarray(angles, dtype=float))


def test_computed_torque_is_rnea_of_the_pd_acceleration(kinova: Any) -> None:
    assert (kinova.nq, kinova.nv) == (9, 6)
    rng = np.random.default_rng(0)
    target = _config(kinova, rng.uniform(-1, 1, 6))
    ctrl = ComputedTorqueController(kinova, target, kp=25.0, kd=7.0)
    model, data = kinova.model, kinova.model.createData()
    for _ in range(3):
        q = _config(kinova, rng.uniform(-2, 2, 6))
        v = rng.normal(size=6)
        a_star = 25.0 * pin.difference(model, q, target) - 7.0 * v
        expected = pin.rnea(model, data, q, v, a_star)
        np.testing.assert_allclose(ctrl(0.0, q, v), expected, rtol=1e-12, atol=1e-10)


def test_joint_pd_is_pd_plus_gravity(kinova: Any) -> None:
    rng = np.random.default_rng(1)
    target = _config(kinova, rng.uniform(-1, 1, 6))
    ctrl = JointPDController(kinova, target, kp=30.0, kd=4.0)
    model, data = kinova.model, kinova.model.createData()
    q = _config(kinova, rng.uniform(-2, 2, 6))
    v = rng.normal(size=6)
    expected = 30.0 * pin.difference(model, q, target) - 4.0 * v
    expected += pin.computeGeneralizedGravity(model, data, q)
    np.testing.assert_allclose(ctrl(0.0, q, v), expected, rtol=1e-12, atol=1e-10)


def test_computed_torque_error_follows_the_closed_form(robot_loader: Any) -> None:
    # the error of every joint, continuous ones included, is a critically damped unit mass
    robot = robot_loader("double_pendulum_continuous")
    assert (robot.nq, robot.nv) == (4, 2)
    target = _config(robot, [0.8, -0.5])
    q0 = _config(robot, [-0.3, 0.4])
    w = 4.0
    ctrl = ComputedTorqueController(robot, target, kp=w * w, kd=2.0 * w)
    # the law evaluated at every RK4 stage (no zero-order hold): the error is RK4's, ~1e-10
    options = SimulationOptions(hold_control=False, record_energy=False)
    sim = simulate(robot, ctrl, (q0, np.zeros(2)), 1.0, 1e-3, options)
    assert sim.success
    e0 = pin.difference(robot.model, q0, target)  # e = q_ref (-) q, e'(0) = 0
    for k in (100, 500, 1000):
        t = sim.t[k]
        expected = (e0 + w * e0 * t) * np.exp(-w * t)
        np.testing.assert_allclose(
            pin.difference(robot.model, sim.q[k], target), expected, atol=1e-8
        )


def test_a_reference_of_the_wrong_sizes_is_named(kinova: Any) -> None:
    q = kinova.q_default
    wrong_v = ReferencePoint(q, np.zeros(kinova.nq), np.zeros(kinova.nv))
    wrong_a = ReferencePoint(q, np.zeros(kinova.nv), np.zeros(kinova.nq))
    wrong_q = ReferencePoint(np.zeros(kinova.nv), np.zeros(kinova.nv), np.zeros(kinova.nv))
    for point, name in ((wrong_v, "v"), (wrong_a, "a"), (wrong_q, "q")):
        for cls in (ComputedTorqueController, JointPDController):
            ctrl = cls(kinova, lambda t, p=point: p)
            with pytest.raises(ShapeError, match=f"reference\\(t\\)\\.{name}"):
                ctrl(0.0, q, np.zeros(kinova.nv))


def test_a_target_with_an_unnormalized_unit_complex_is_refused(kinova: Any) -> None:
    target = kinova.q_default.copy()
    target[:2] = (2.0, 0.0)  # (cos, sin) of the first continuous joint, norm 2
    for cls in (ComputedTorqueController, JointPDController):
        with pytest.raises(InvalidInputError, match="reference"):
            cls(kinova, target)
