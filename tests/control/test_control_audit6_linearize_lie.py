"""linearize about a moving point on spherical and planar joints, new-user sweep audit6.

The state is ``x = (q (-) q_eq, v - v_eq)``. On a Lie-group joint moving at ``v_eq`` the
rate of ``q (-) q_eq`` is ``Jlog(x) v``, whose derivative at ``x = 0`` is ``-1/2 ad(v_eq)``,
not 0: before, ``A[:nv, :nv]`` was 0 (entries up to 0.4 missing at |v_eq| ~ 1 rad/s). Zero
at rest (the usual equilibrium). Reference: central differences of
``(pin.dDifference(q_eq, q_eq (+) x_1, ARG1) (v_eq + x_2), pin.aba(...))``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import linearize
from taskspace.model import Robot
from tests._lie_robots import two_body_robot


def _robot(root: pin.JointModel, name: str) -> Robot:
    return two_body_robot(root, name)


def _finite_differences(robot: Robot, q, v, tau):  # type: ignore[no-untyped-def]
    model, data, nv = robot.model, robot.model.createData(), robot.nv

    def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        qq, vv = pin.integrate(model, q, x[:nv]), v + x[nv:]
        rate = pin.dDifference(model, q, qq, pin.ArgumentPosition.ARG1) @ vv
        return np.concatenate([rate, pin.aba(model, data, qq, vv, tau + u)])

    eps = 1e-6
    A = np.zeros((2 * nv, 2 * nv))
    B = np.zeros((2 * nv, nv))
    for i in range(2 * nv):
        e = np.zeros(2 * nv)
        e[i] = eps
        A[:, i] = (f(e, np.zeros(nv)) - f(-e, np.zeros(nv))) / (2 * eps)
    for i in range(nv):
        e = np.zeros(nv)
        e[i] = eps
        B[:, i] = (f(np.zeros(2 * nv), e) - f(np.zeros(2 * nv), -e)) / (2 * eps)
    return A, B


@pytest.mark.parametrize(
    "name, root", [("spherical", pin.JointModelSpherical), ("planar", pin.JointModelPlanar)]
)
def test_linearization_about_a_moving_point(name: str, root: type) -> None:
    robot = _robot(root(), name)
    rng = np.random.default_rng(5)
    q = robot.random_configuration(rng)
    v = rng.uniform(-1.0, 1.0, robot.nv)
    tau = rng.normal(size=robot.nv)
    system = linearize(robot, q, v, tau)
    A, B = _finite_differences(robot, q, v, tau)
    np.testing.assert_allclose(system.A, A, atol=1e-6)
    np.testing.assert_allclose(system.B, B, atol=1e-6)
