from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control import (
    RiccatiOptions,
    RiccatiStatus,
    controllability,
    dlqr,
    is_controllable,
    is_stable,
    lqr,
    lyapunov_check,
    solve_continuous_riccati,
    solve_discrete_lyapunov,
    solve_discrete_riccati,
    solve_lyapunov,
    solve_riccati_differential,
    solve_riccati_recursion,
    stability,
)
from taskspace.errors import InvalidInputError, ShapeError, SolverError


def _random_system(rng, n=6, m=2):  # type: ignore[no-untyped-def]
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    L = rng.normal(size=(n, n))
    Q = L @ L.T + 0.1 * np.eye(n)
    R = np.diag(rng.uniform(0.5, 2.0, m))
    return A, B, Q, R


@pytest.mark.parametrize("seed", range(5))
def test_care_vs_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    A, B, Q, R = _random_system(rng)
    ref = sla.solve_continuous_are(A, B, Q, R)
    res = solve_continuous_riccati(A, B, Q, R)
    assert res.success and res.residual < 1e-9
    np.testing.assert_allclose(res.P, ref, rtol=1e-7, atol=1e-8)
    # Newton-Kleinman from the stabilizing gain of a shifted problem
    K0 = lqr(A + 1.0 * np.eye(6), B, Q, R).K
    nk = solve_continuous_riccati(
        A, B, Q, R, RiccatiOptions(method="newton_kleinman"), initial_gain=K0
    )
    assert nk.status is RiccatiStatus.SOLVED and nk.iterations < 30
    np.testing.assert_allclose(nk.P, ref, rtol=1e-7, atol=1e-8)


@pytest.mark.parametrize("seed", range(5))
def test_dare_vs_scipy(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    A, B, Q, R = _random_system(rng)
    ref = sla.solve_discrete_are(A, B, Q, R)
    res = solve_discrete_riccati(A, B, Q, R)
    np.testing.assert_allclose(res.P, ref, rtol=1e-7, atol=1e-8)
    assert res.residual < 1e-9


def test_dare_with_singular_A() -> None:
    A = np.array([[0.0, 1.0], [0.0, 0.0]])  # nilpotent
    B = np.array([[0.0], [1.0]])
    res = solve_discrete_riccati(A, B, np.eye(2), 1.0)
    np.testing.assert_allclose(
        res.P, sla.solve_discrete_are(A, B, np.eye(2), np.eye(1)), atol=1e-10
    )


def test_lqr_closed_loop_is_stable_and_optimal() -> None:
    rng = np.random.default_rng(7)
    A, B, Q, R = _random_system(rng)
    res = lqr(A, B, Q, R)
    assert res.success and res.stable
    assert np.max(res.closed_loop_eigenvalues.real) < 0
    assert stability(A - B @ res.K).stable
    # optimal cost x0^T P x0 equals the integral of the cost along the closed loop
    x0 = rng.normal(size=6)
    Acl = A - B @ res.K
    W = sla.solve_continuous_lyapunov(Acl.T, -(Q + res.K.T @ R @ res.K))
    assert x0 @ W @ x0 == pytest.approx(x0 @ res.P @ x0, rel=1e-8)
    d = dlqr(A * 0.3, B, Q, R)
    assert d.stable and np.max(np.abs(d.closed_loop_eigenvalues)) < 1


def test_double_integrator_lqr_analytic() -> None:
    # x'' = u, Q = I, R = 1: K = [1, sqrt(3)]
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([0.0, 1.0])
    np.testing.assert_allclose(lqr(A, B, np.eye(2), 1.0).K, [[1.0, np.sqrt(3.0)]], atol=1e-10)


def test_controllability_rank() -> None:
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    assert is_controllable(A, np.array([[0.0], [1.0]]))
    # input only on the position of a double integrator: the velocity is uncontrollable
    res = controllability(A, np.array([[1.0], [0.0]]))
    assert not res.controllable and res.rank == 1
    # decoupled modes, input on one only
    A2 = np.diag([-1.0, 2.0])
    res2 = controllability(A2, np.array([[1.0], [0.0]]))
    assert not res2.controllable
    np.testing.assert_allclose(res2.uncontrollable_modes, [2.0])
    assert not res2.stabilizable()
    res3 = controllability(np.diag([2.0, -1.0]), np.array([[1.0], [0.0]]))
    assert res3.stabilizable()
    # repeated eigenvalue with a single input: never controllable
    assert not is_controllable(np.eye(2), np.array([[1.0], [1.0]]))


def test_lyapunov_vs_scipy_and_check() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 5)) - 4.0 * np.eye(5)
    Q = np.eye(5)
    P = solve_lyapunov(A, Q)
    np.testing.assert_allclose(P, sla.solve_continuous_lyapunov(A.T, -Q), atol=1e-10)
    cert = lyapunov_check(A, P)
    assert cert.valid and cert.min_eigenvalue_P > 0 and cert.max_eigenvalue_decrease < 0
    # V(x(t)) = x(t)^T P x(t) decreases along the exact trajectories x(t) = expm(A t) x0
    x0 = rng.normal(size=5)
    values = [cert.value(P, sla.expm(A * t) @ x0) for t in np.linspace(0, 2, 41)]
    assert np.all(np.diff(values) < 0)
    Ad = 0.4 * rng.normal(size=(5, 5)) / np.sqrt(5)
    assert is_stable(Ad, discrete=True)
    Pd = solve_discrete_lyapunov(Ad, Q)
    np.testing.assert_allclose(Pd, sla.solve_discrete_lyapunov(Ad.T, Q), atol=1e-10)
    assert lyapunov_check(Ad, Pd, discrete=True).valid
    # unstable A: the identity is not a Lyapunov function
    assert not lyapunov_check(np.diag([1.0, -1.0]), np.eye(2)).valid


def test_stability_by_eigenvalues() -> None:
    assert is_stable(np.diag([-1.0, -0.1]))
    assert not is_stable(np.array([[0.0, 1.0], [-1.0, 0.0]]))  # undamped oscillator
    assert not is_stable(np.diag([-1.0, -0.1]), margin=0.5)
    assert is_stable(np.diag([0.5, -0.9]), discrete=True)
    assert not is_stable(np.diag([1.0, 0.5]), discrete=True)


def test_finite_horizon_riccati() -> None:
    # scalar x' = u, q = r = 1, Qf = 0: P(t) = tanh(T - t)
    res = solve_riccati_differential([[0.0]], [[1.0]], 1.0, 1.0, 0.0, horizon=3.0, steps=300)
    np.testing.assert_allclose(res.P[:, 0, 0], np.tanh(3.0 - res.times), atol=1e-9)
    np.testing.assert_allclose(res.K[:, 0, 0], np.tanh(3.0 - res.times), atol=1e-9)
    # long horizon -> algebraic solution
    rng = np.random.default_rng(11)
    A, B, Q, R = _random_system(rng, n=3, m=1)
    A = A - 2 * np.eye(3)
    long = solve_riccati_differential(A, B, Q, R, np.zeros((3, 3)), horizon=20.0, steps=4000)
    np.testing.assert_allclose(long.P[0], sla.solve_continuous_are(A, B, Q, R), atol=1e-7)


def test_discrete_recursion_matches_brute_force() -> None:
    # minimize x_N' Qf x_N + sum x_k' Q x_k + u_k' R u_k as one least-squares problem in u
    rng = np.random.default_rng(5)
    n, m, N = 3, 2, 4
    A, B, Q, R = _random_system(rng, n, m)
    A *= 0.5
    Qf = 2 * np.eye(n)
    x0 = rng.normal(size=n)
    # x_k = A^k x0 + sum_j A^(k-1-j) B u_j
    blocks, free = [], []
    for k in range(N + 1):
        row = np.zeros((n, N * m))
        for j in range(k):
            row[:, j * m : (j + 1) * m] = np.linalg.matrix_power(A, k - 1 - j) @ B
        blocks.append(row)
        free.append(np.linalg.matrix_power(A, k) @ x0)
    Lq, Lf, Lr = np.linalg.cholesky(Q), np.linalg.cholesky(Qf), np.linalg.cholesky(R)
    rows = [Lq.T @ blocks[k] for k in range(N)] + [Lf.T @ blocks[N]]
    rhs = [-Lq.T @ free[k] for k in range(N)] + [-Lf.T @ free[N]]
    for j in range(N):
        r = np.zeros((m, N * m))
        r[:, j * m : (j + 1) * m] = Lr.T
        rows.append(r)
        rhs.append(np.zeros(m))
    M, y = np.vstack(rows), np.concatenate(rhs)
    u = np.linalg.lstsq(M, y, rcond=None)[0]
    best = float(np.sum((M @ u - y) ** 2))
    res = solve_riccati_recursion(A, B, Q, R, Qf, N)
    assert res.cost(x0) == pytest.approx(best, rel=1e-10)
    np.testing.assert_allclose(-res.K[0] @ x0, u[:m], atol=1e-10)


def test_error_paths() -> None:
    A = np.diag([-1.0, 2.0])
    B_bad = np.array([[1.0], [0.0]])
    with pytest.raises(
        InvalidInputError,
        match=r"\(A, B\) is not controllable: .* rank 1 < n = 2; uncontrollable modes .*\[2",
    ):
        lqr(A, B_bad, np.eye(2), 1.0)
    from taskspace.control import LQROptions

    with pytest.raises(InvalidInputError, match="not stabilizable"):
        lqr(A, B_bad, np.eye(2), 1.0, LQROptions(require_controllable=False))
    ok = lqr(np.diag([2.0, -1.0]), B_bad, np.eye(2), 1.0, LQROptions(require_controllable=False))
    assert ok.stable
    with pytest.raises(InvalidInputError, match="R must be positive definite"):
        lqr(np.eye(2), np.eye(2), np.eye(2), np.diag([1.0, 0.0]))
    with pytest.raises(InvalidInputError, match="Q must be symmetric"):
        lqr(np.eye(2), np.eye(2), np.array([[1.0, 1.0], [0.0, 1.0]]), 1.0)
    with pytest.raises(ShapeError, match=r"B must have shape \(2, -1\)"):
        lqr(np.eye(2), np.ones((3, 1)), np.eye(2), 1.0)
    with pytest.raises(InvalidInputError, match="A has non-finite"):
        lqr(np.array([[np.nan, 0], [0, 1]]), np.eye(2), np.eye(2), 1.0)
    with pytest.raises(InvalidInputError, match="newton_kleinman needs a stabilizing initial gain"):
        solve_continuous_riccati(
            np.eye(2), np.eye(2), np.eye(2), 1.0, RiccatiOptions(method="newton_kleinman")
        )
    with pytest.raises(
        InvalidInputError,
        match="unknown Riccati method 'qz'; valid methods are: schur, newton_kleinman",
    ):
        solve_continuous_riccati(np.eye(2), np.eye(2), np.eye(2), 1.0, RiccatiOptions(method="qz"))
    with pytest.raises(SolverError, match="no stabilizing solution"):
        # an undamped oscillator with no input: the Hamiltonian has imaginary-axis eigenvalues
        solve_continuous_riccati(
            np.array([[0.0, 1.0], [-1.0, 0.0]]),
            np.zeros((2, 1)),
            np.zeros((2, 2)),
            1.0,
        )
    with pytest.raises(SolverError, match="no unique solution"):
        solve_lyapunov(np.array([[0.0, 1.0], [-1.0, 0.0]]), np.eye(2))
    with pytest.raises(InvalidInputError, match="N must be an integer >= 1"):
        solve_riccati_recursion(np.eye(1), np.eye(1), 1.0, 1.0, 1.0, 0)
    with pytest.raises(InvalidInputError, match=r"horizon \[s\] must be finite and > 0"):
        solve_riccati_differential(np.eye(1), np.eye(1), 1.0, 1.0, 1.0, horizon=0.0)
