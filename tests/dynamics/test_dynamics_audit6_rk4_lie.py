"""RK4 of taskspace.dynamics on Lie-group joints (spherical, planar, free flyer), audit6 sweep.

Before: rk4_step combined the stage velocities in the tangent space at ``q`` without the
inverse of the exponential map's differential, so on spherical, planar and free-flyer joints
the "fourth-order" scheme was second order (error ratio 4.0 per halved step on each; 3.6e-7
on a free flyer at dt = 1e-3 where fourth order gives ~1e-11). Now the stages follow
``Theta' = dexp^-1_Theta(v)`` (Runge-Kutta-Munthe-Kaas; ``pin.dIntegrate``), fourth order on
every joint. Reference: scipy's DOP853 (rtol 1e-13) on the ambient ODE written out here
(quaternion ``q' = 1/2 q (x) (w, 0)``, planar ``(x, y, cos, sin)'``) with Pinocchio's ABA;
vector-space robots against a classical RK4 written out on ``pin.aba``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from taskspace.dynamics import SimulationOptions, simulate
from taskspace.model import Robot
from tests._lie_robots import two_body_robot


def _quat_rate(quat: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``d/dt (x, y, z, w)`` of a unit quaternion turning at the body rate ``w``."""
    x, y, z, s = quat
    # q (x) (w, 0), Hamilton product, Pinocchio's (x, y, z, w) order
    return 0.5 * np.array(
        [
            s * w[0] + y * w[2] - z * w[1],
            s * w[1] + z * w[0] - x * w[2],
            s * w[2] + x * w[1] - y * w[0],
            -x * w[0] - y * w[1] - z * w[2],
        ]
    )


def _qdot(model: pin.Model, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.zeros(model.nq)
    for joint in model.joints[1:]:
        iq, iv, kind = joint.idx_q, joint.idx_v, joint.shortname()
        if kind == "JointModelSpherical":
            out[iq : iq + 4] = _quat_rate(q[iq : iq + 4], v[iv : iv + 3])
        elif kind == "JointModelFreeFlyer":
            quat = q[iq + 3 : iq + 7]
            R = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
            out[iq : iq + 3] = R @ v[iv : iv + 3]
            out[iq + 3 : iq + 7] = _quat_rate(quat, v[iv + 3 : iv + 6])
        elif kind == "JointModelPlanar":
            c, s = q[iq + 2], q[iq + 3]
            vx, vy, w = v[iv : iv + 3]
            out[iq : iq + 4] = [c * vx - s * vy, s * vx + c * vy, -s * w, c * w]
        else:
            assert joint.nq == joint.nv == 1, kind
            out[iq] = v[iv]
    return out


def _reference(model: pin.Model, q0: np.ndarray, v0: np.ndarray, T: float) -> np.ndarray:
    data = model.createData()
    nq = model.nq

    def rhs(_t: float, x: np.ndarray) -> np.ndarray:
        q, v = pin.normalize(model, x[:nq]), x[nq:]
        return np.concatenate([_qdot(model, q, v), pin.aba(model, data, q, v, np.zeros(model.nv))])

    sol = solve_ivp(rhs, (0.0, T), np.concatenate([q0, v0]), "DOP853", rtol=1e-13, atol=1e-13)
    return pin.normalize(model, sol.y[:nq, -1])


def _robot(root: pin.JointModel, name: str, gravity: bool) -> Robot:
    return two_body_robot(root, name, gravity)


ROOTS = {
    "spherical": (pin.JointModelSpherical, True),
    "planar": (pin.JointModelPlanar, True),
    "free_flyer": (pin.JointModelFreeFlyer, False),
}


@pytest.mark.parametrize("name", sorted(ROOTS))
def test_rk4_is_fourth_order_on_lie_group_joints(name: str) -> None:
    make, gravity = ROOTS[name]
    robot = _robot(make(), name, gravity)
    rng = np.random.default_rng(3)
    q0 = robot.random_configuration(rng)
    v0 = rng.uniform(-1.5, 1.5, robot.nv)
    T = 1.0
    ref = _reference(robot.model, q0, v0, T)
    errors = []
    for dt in (0.02, 0.01):
        sim = simulate(robot, None, (q0, v0), T, dt, SimulationOptions(record_energy=False))
        errors.append(float(np.linalg.norm(pin.difference(robot.model, ref, sim.final_q))))
    order = math.log2(errors[0] / errors[1])
    assert order > 3.6, (errors, order)
    assert errors[1] < 1e-5, errors


def test_vector_space_robots_keep_classical_rk4(robot_loader: Any) -> None:
    robot = robot_loader("ur5")
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(4)
    q, v = robot.random_configuration(rng), rng.normal(size=6)
    dt = 0.01
    sim = simulate(robot, None, (q, v), 0.05, dt, SimulationOptions(record_energy=False))
    zero = np.zeros(6)
    for _ in range(5):  # classical RK4 on (q, v), q a vector
        a1 = pin.aba(model, data, q, v, zero)
        a2 = pin.aba(model, data, q + dt / 2 * v, v + dt / 2 * a1, zero)
        v2 = v + dt / 2 * a1
        a3 = pin.aba(model, data, q + dt / 2 * v2, v + dt / 2 * a2, zero)
        v3 = v + dt / 2 * a2
        a4 = pin.aba(model, data, q + dt * v3, v + dt * a3, zero)
        v4 = v + dt * a3
        q, v = q + dt / 6 * (v + 2 * v2 + 2 * v3 + v4), v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    np.testing.assert_allclose(sim.final_q, q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(sim.final_v, v, rtol=0, atol=1e-12)
