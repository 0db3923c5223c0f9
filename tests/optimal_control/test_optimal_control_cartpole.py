from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model.robot import Robot
from taskspace.optimal_control import (
    CartPoleBalance,
    FittedValueIterationOptions,
    cartpole_acceleration,
    fitted_value_iteration,
    make_grid,
    rk4_step,
)


def test_closed_form_matches_aba_on_the_cartpole_robot() -> None:
    robot = Robot.load("cartpole")
    data = robot.model.createData()
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, (10, 2))
    v = rng.uniform(-2, 2, (10, 2))
    F = rng.uniform(-10, 10, 10)
    ref = np.array(
        [pin.aba(robot.model, data, q[k], v[k], np.array([F[k], 0.0])) for k in range(10)]
    )
    assert cartpole_acceleration(q, v, F) == pytest.approx(ref, rel=1e-9, abs=1e-9)


def test_cartpole_balancing_on_a_4d_grid() -> None:
    prob = CartPoleBalance()
    grid = make_grid(
        [
            np.linspace(-1.5, 1.5, 9),
            np.linspace(-0.6, 0.6, 11),
            np.linspace(-3, 3, 9),
            np.linspace(-4, 4, 11),
        ]
    )
    dt = 0.05
    res = fitted_value_iteration(
        grid,
        np.linspace(-20, 20, 9),
        prob.dynamics,
        prob.cost,
        FittedValueIterationOptions(dt=dt, substeps=2, discount_rate=0.5),
    )
    assert res.success
    x = np.array([[0.3, 0.15, 0.0, 0.0]])
    worst = np.zeros(4)
    for _ in range(100):
        x = rk4_step(prob.dynamics, x, res.control(x, prob.dynamics, prob.cost, dt), dt, 4)
        worst = np.maximum(worst, np.abs(x[0]))
    # The pole stays up (CartPole-v1's limits: 12 deg, 2.4 m) for 5 s.
    assert worst[1] < np.deg2rad(12) and worst[0] < 2.4
    # Without control it falls.
    y = np.array([[0.3, 0.15, 0.0, 0.0]])
    y = rk4_step(prob.dynamics, y, np.zeros((1, 1)), 1.0, 50)
    assert abs(y[0, 1]) > np.deg2rad(12)
