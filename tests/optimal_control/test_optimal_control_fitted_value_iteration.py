from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control import dlqr, lqr
from taskspace.errors import InvalidInputError
from taskspace.optimal_control import (
    DoubleIntegrator,
    FittedValueIterationOptions,
    PendulumSwingUp,
    fitted_value_iteration,
    geometric_axis,
    make_grid,
    min_time,
    min_time_switching_curve,
    rk4_step,
    wrap_angle,
)


def _zoh(A, B, dt):  # type: ignore[no-untyped-def]
    n, m = B.shape
    M = sla.expm(np.block([[A, B], [np.zeros((m, n + m))]]) * dt)
    return M[:n, :n], M[:n, n:]


def test_multilinear_interpolation_is_exact_for_multilinear_functions() -> None:
    rng = np.random.default_rng(0)
    grid = make_grid([np.sort(rng.uniform(-1, 1, 7)), np.linspace(0, 2, 5), [0.0, 0.5, 3.0]])
    f = lambda X: 1 + 2 * X[:, 0] - X[:, 1] + 3 * X[:, 0] * X[:, 1] * X[:, 2]  # noqa: E731
    X = np.stack([rng.uniform(a[0], a[-1], 50) for a in grid.axes], axis=1)
    assert grid.interpolate(f(grid.points()), X) == pytest.approx(f(X))
    W = grid.interpolation_matrix(X)
    assert np.allclose(W.sum(axis=1), 1.0) and W.min() >= 0.0


def test_periodic_axis_wraps() -> None:
    th = np.linspace(0, 2 * np.pi, 13)[:-1]
    grid = make_grid([th], periods=[2 * np.pi])
    v = np.cos(grid.points()[:, 0])
    x = np.array([[2 * np.pi - 0.1], [-0.1], [4 * np.pi - 0.1]])
    out = grid.interpolate(v, x)
    assert out[0] == pytest.approx(out[1]) and out[1] == pytest.approx(out[2])
    # Between the grid points 2 pi - h (= -h) and 0: linear interpolation of cos.
    h = th[1]
    expected = np.cos(h) + (1 - np.cos(h)) * (h - 0.1) / h
    assert out[0] == pytest.approx(expected)
    with pytest.raises(InvalidInputError, match="period"):
        make_grid([np.linspace(0, 2 * np.pi, 13)], periods=[2 * np.pi])


def test_value_near_origin_matches_lqr_riccati() -> None:
    # Linear dynamics, quadratic cost: the discrete problem that fitted value iteration solves
    # (input held for dt, cost l dt) is the discrete LQR of the zero-order-hold model; its
    # value is x^T P x with P from the DARE. The geometric grid keeps the relative
    # interpolation error uniform near the origin.
    prob = DoubleIntegrator()
    dt = 1.0
    ax = geometric_axis(1.2, 1e-2, 1.12)
    grid = make_grid([ax, ax])
    actions = geometric_axis(2.0, 1e-3, 1.1)
    res = fitted_value_iteration(
        grid, actions, prob.dynamics, prob.cost, FittedValueIterationOptions(dt=dt, substeps=4)
    )
    assert res.success
    Ad, Bd = _zoh(prob.A, prob.B, dt)
    P = dlqr(Ad, Bd, np.eye(2) * dt, np.eye(1) * dt).P
    X = grid.points()
    radius = np.linalg.norm(X, axis=1)
    near = (radius > 0.25) & (radius < 0.6)
    J_lqr = np.einsum("ki,ij,kj->k", X, P, X)
    rel = res.J[near] / J_lqr[near] - 1.0
    assert np.abs(rel).max() < 0.01
    # The continuous LQR is the dt -> 0 limit (here dt = 1 s is far from it: O(dt) apart).
    Pc = lqr(prob.A, prob.B, np.eye(2), 1.0).P
    assert not np.allclose(P / dt, Pc, rtol=0.01)


@pytest.mark.slow
def test_pendulum_value_near_the_upright_matches_the_discrete_lqr() -> None:
    # The swing-up (periodic angle, |u| <= 4 N m < m g l) near the upright. The reference is
    # the LQR of the discrete problem that fitted value iteration solves: the RK4 map
    # linearized at the upright (exact: RK4's stages all sit at the equilibrium), stage cost
    # (Q, R) dt, discount gamma = exp(-rho dt) (the DARE of sqrt(gamma) A, sqrt(gamma) B).
    # Three discretization errors are kept below 1 %: the interpolation error (a geometric
    # grid about the upright: the cell size is proportional to the distance, down to 1e-4),
    # the control error (local action refinement to 8 / 2^13 N m) and the nonlinearity
    # (O(|x|), small in the neighbourhood). Inside it, LQR's torque stays below the bound,
    # so the bounded problem has the unbounded value.
    prob = PendulumSwingUp()
    dt, rho, substeps = 0.2, 1.0, 2
    th = np.pi + geometric_axis(3.0, 1e-4, 1.15)
    om = geometric_axis(8.0, 3e-4, 1.15)
    grid = make_grid([th, om], periods=[2 * np.pi, 0.0])
    A, B = prob.linearization()
    lin = lambda X, U: X @ A.T + U @ B.T  # noqa: E731
    Ad = rk4_step(lin, np.eye(2), np.zeros((2, 1)), dt, substeps).T
    Bd = rk4_step(lin, np.zeros((1, 2)), np.ones((1, 1)), dt, substeps).T
    g = np.sqrt(np.exp(-rho * dt))
    ref = dlqr(g * Ad, g * Bd, np.diag(prob.q) * dt, np.eye(1) * prob.r * dt)
    X = grid.points()
    d = np.stack([wrap_angle(X[:, 0] - np.pi), X[:, 1]], axis=1)
    J_lqr = np.einsum("ki,ij,kj->k", d, ref.P, d)
    near = (J_lqr > 0.003**2) & (J_lqr < 0.1**2)  # x^T P x in [1e-5, 1e-2]: 7000 points
    assert np.abs(d[near] @ ref.K.T).max() < 4.0
    worst = {}
    for refinements in (0, 12):
        res = fitted_value_iteration(
            grid,
            np.linspace(-4, 4, 9),
            prob.dynamics,
            prob.cost,
            FittedValueIterationOptions(
                dt=dt, substeps=substeps, discount_rate=rho, refinements=refinements
            ),
        )
        assert res.success
        worst[refinements] = np.abs(res.J[near] / J_lqr[near] - 1.0).max()
    assert worst[12] < 0.01, worst
    # The greedy torque is LQR's within the final control resolution (plus the rest).
    u_lqr = -(d[near] @ ref.K.T)[:, 0]
    assert np.abs(res.greedy_action[near, 0] - u_lqr).max() < 0.05
    # Without the refinement the 1 N m action spacing alone costs far more than 1 %.
    assert worst[0] > 0.1, worst


def test_min_time_double_integrator_switching_curve() -> None:
    prob = DoubleIntegrator()
    errors = []
    for n in (41, 161):
        ax = np.linspace(-2.0, 2.0, n)
        h = ax[1] - ax[0]
        grid = make_grid([ax, ax])
        res = fitted_value_iteration(
            grid,
            [-1.0, 1.0],
            prob.dynamics,
            prob.unit_cost,
            FittedValueIterationOptions(dt=0.05, substeps=1),
            target=lambda X, h=h: np.max(np.abs(X), axis=1) <= 1.01 * h,
        )
        assert res.success
        u = res.actions[res.policy, 0].reshape(n, n)  # axis 0: x1, axis 1: x2
        err = 0.0
        for j, v in enumerate(ax):
            if not 0.3 < abs(v) < 1.2:
                continue
            flips = np.flatnonzero(np.diff(u[:, j]) != 0)
            assert flips.size == 1  # bang-bang: one switch per velocity
            x_switch = ax[flips[0]] + h / 2
            err = max(err, abs(x_switch - float(min_time_switching_curve(v))))
            # Above the curve (larger x1) decelerate: u = -1; below: u = +1.
            assert u[flips[0] + 1, j] == -1.0 and u[flips[0], j] == 1.0
        errors.append(err)
        X = grid.points()
        inside = np.max(np.abs(X), axis=1) < 1.0
        assert np.median(np.abs(res.J - min_time(X))[inside]) < (0.1 if n > 100 else 0.2)
    # Semi-Lagrangian schemes converge like sqrt(h) for non-smooth values: the switching
    # curve approaches the analytic parabola as the grid is refined.
    assert errors[1] < 0.2
    assert errors[1] < 0.75 * errors[0]


def test_pendulum_swing_up_and_hjb_residual() -> None:
    prob = PendulumSwingUp()
    th = np.linspace(0, 2 * np.pi, 61)[:-1]
    om = np.linspace(-8, 8, 61)
    grid = make_grid([th, om], periods=[2 * np.pi, 0.0])
    dt = 0.05
    # |u| <= 4 N m < m g l: the pendulum must swing to gain energy.
    res = fitted_value_iteration(
        grid,
        np.linspace(-4, 4, 9),
        prob.dynamics,
        prob.cost,
        FittedValueIterationOptions(dt=dt, substeps=1, discount_rate=0.2),
    )
    assert res.success
    up = np.argmin(res.J)
    assert abs(wrap_angle(grid.points()[up, 0] - np.pi)) < 1e-9
    x = np.array([[0.0, 0.0]])
    for _ in range(200):
        x = rk4_step(prob.dynamics, x, res.control(x, prob.dynamics, prob.cost, dt), dt, 4)
    assert abs(wrap_angle(x[0, 0] - np.pi)) < 0.1 and abs(x[0, 1]) < 0.2
    # The HJB residual is small where J is smooth (median) compared with the cost scale.
    assert np.median(np.abs(res.hjb_residual)) < 0.2 * np.median(
        prob.cost(grid.points(), np.zeros((grid.size, 1)))
    )


def test_errors() -> None:
    prob = DoubleIntegrator()
    grid = make_grid([np.linspace(-1, 1, 3), np.linspace(-1, 1, 3)])
    with pytest.raises(InvalidInputError, match="nonnegative"):
        fitted_value_iteration(grid, [0.0], prob.dynamics, lambda X, U: -np.ones(len(X)))
    with pytest.raises(InvalidInputError, match="dt"):
        fitted_value_iteration(
            grid, [0.0], prob.dynamics, prob.cost, FittedValueIterationOptions(dt=0.0)
        )
    with pytest.raises(InvalidInputError, match="refinements"):
        fitted_value_iteration(
            grid, [0.0], prob.dynamics, prob.cost, FittedValueIterationOptions(refinements=-1)
        )
    with pytest.raises(InvalidInputError, match="increasing"):
        make_grid([[0.0, 0.0, 1.0]])
