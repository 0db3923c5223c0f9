from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.dynamics import (
    coriolis_torque,
    gravity_torque,
    inverse_dynamics,
    mass_matrix,
    nonlinear_effects,
    pendulum_acceleration,
    pendulum_energy,
    pendulum_torque,
)
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError


@pytest.mark.parametrize("name", ["panda", "ur5", "talos"])
def test_newton_euler_uses_match_pinocchio(robot_loader, name: str) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader(name)
    rng = np.random.default_rng(3)
    model, data = robot.model, robot.model.createData()
    for _ in range(3):
        q = robot.random_configuration(rng, base_box=0.5)
        v = rng.normal(size=robot.nv)
        a = rng.normal(size=robot.nv)
        np.testing.assert_allclose(
            gravity_torque(robot, q), pin.computeGeneralizedGravity(model, data, q), atol=1e-9
        )
        np.testing.assert_allclose(
            nonlinear_effects(robot, q, v), pin.nonLinearEffects(model, data, q, v), atol=1e-9
        )
        C = pin.computeCoriolisMatrix(model, data, q, v)
        np.testing.assert_allclose(coriolis_torque(robot, q, v), C @ v, atol=1e-8)
        M_ref = pin.crba(model, data, q)
        M_ref = np.triu(M_ref) + np.triu(M_ref, 1).T
        M = mass_matrix(robot, q)
        np.testing.assert_allclose(M, M_ref, atol=1e-9)
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        # u = M a + C v + G (slide 5:28)
        np.testing.assert_allclose(
            inverse_dynamics(robot, q, v, a), M_ref @ a + C @ v + data.g, atol=1e-8
        )


def test_pendulum_euler_lagrange_matches_rnea(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("pendulum")
    rng = np.random.default_rng(0)
    data = robot.model.createData()
    g = float(np.linalg.norm(robot.model.gravity.linear))
    for theta, w, acc in rng.uniform(-3, 3, size=(20, 3)):
        u_ref = pin.rnea(robot.model, data, np.array([theta]), np.array([w]), np.array([acc]))[0]
        assert pendulum_torque(theta, acc, mass=1.0, length=1.0, gravity=g) == pytest.approx(
            u_ref, abs=1e-10
        )
        a_ref = pin.aba(robot.model, data, np.array([theta]), np.array([w]), np.array([acc]))[0]
        assert pendulum_acceleration(theta, acc, gravity=g) == pytest.approx(a_ref, abs=1e-10)
        e_ref = pin.computeKineticEnergy(
            robot.model, data, np.array([theta]), np.array([w])
        ) + pin.computePotentialEnergy(robot.model, data, np.array([theta]))
        assert pendulum_energy(theta, w, gravity=g) == pytest.approx(e_ref, abs=1e-10)


def test_pendulum_inertia_term() -> None:
    # (m l^2 + I) theta'' at theta = 0
    assert pendulum_torque(0.0, 2.0, mass=2.0, length=0.5, inertia=0.1) == pytest.approx(1.2)
    np.testing.assert_allclose(pendulum_torque(np.array([0.0, np.pi / 2]), 0.0), [0.0, 9.81])


def test_error_paths(panda) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ShapeError, match=r"a must have shape \(7,\), got \(6,\)"):
        inverse_dynamics(panda, panda.q_default, np.zeros(7), np.zeros(6))
    with pytest.raises(NotFiniteError, match="v has non-finite"):
        nonlinear_effects(panda, panda.q_default, np.full(7, np.nan))
    with pytest.raises(InvalidInputError, match=r"length \[m\] must be finite and > 0"):
        pendulum_torque(0.0, 0.0, length=0.0)
    with pytest.raises(NotFiniteError, match="theta has non-finite"):
        pendulum_torque(np.nan, 0.0)
