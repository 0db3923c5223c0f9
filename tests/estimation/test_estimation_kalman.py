"""Kalman family against analytic references (slide 6:10 identities, information form, LSQ)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.stats

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, TaskspaceError
from taskspace.estimation.batch_kalman_filter import BatchKalmanFilter
from taskspace.estimation.consistency import chi2_bounds, nees
from taskspace.estimation.constant_velocity_filter import (
    ConstantVelocityKalmanFilter,
    constant_velocity_model,
)
from taskspace.estimation.extended_kalman_filter import ExtendedKalmanFilter
from taskspace.estimation.gaussian import gaussian_product, gaussian_propagation
from taskspace.estimation.kalman_filter import KalmanFilter, KalmanFilterOptions
from taskspace.estimation.rts_smoother import rts_smooth
from taskspace.estimation.unscented_kalman_filter import UnscentedKalmanFilter


def random_spd(rng: np.random.Generator, n: int, scale: float = 1.0) -> np.ndarray:
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T + n * np.eye(n)) / n


def info_form_update(x, P, z, H, R):
    """Reference posterior in information form: P+ = (P^-1 + H^T R^-1 H)^-1."""
    Pi = np.linalg.inv(P)
    Ri = np.linalg.inv(R)
    Pn = np.linalg.inv(Pi + H.T @ Ri @ H)
    return Pn @ (Pi @ x + H.T @ Ri @ z), Pn


# ---------------------------------------------------------------- Gaussian identities


def test_gaussian_product_matches_pointwise_density_product():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=3), rng.normal(size=3)
    A, B = random_spd(rng, 3), random_spd(rng, 3, 0.5)
    g, log_c = gaussian_product(a, A, b, B)
    for x in rng.normal(size=(5, 3)):
        lhs = scipy.stats.multivariate_normal(a, A).logpdf(x) + scipy.stats.multivariate_normal(
            b, B
        ).logpdf(x)
        rhs = scipy.stats.multivariate_normal(g.mean, g.cov).logpdf(x) + log_c
        assert lhs == pytest.approx(rhs, abs=1e-10)


def test_gaussian_propagation_matches_monte_carlo():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=2), rng.normal(size=3)
    A, B = random_spd(rng, 2, 0.3), random_spd(rng, 3)
    F = rng.normal(size=(2, 3))
    g = gaussian_propagation(a, A, F, b, B)
    y = rng.multivariate_normal(b, B, size=200_000)
    x = a + y @ F.T + rng.multivariate_normal(np.zeros(2), A, size=200_000)
    np.testing.assert_allclose(g.mean, x.mean(0), atol=0.02)
    np.testing.assert_allclose(g.cov, np.cov(x.T), atol=0.05)


# ---------------------------------------------------------------- linear KF


def test_kf_update_with_identity_H_is_gaussian_product():
    rng = np.random.default_rng(2)
    a, z = rng.normal(size=3), rng.normal(size=3)
    A, B = random_spd(rng, 3), random_spd(rng, 3, 0.2)
    kf = KalmanFilter(np.eye(3), np.eye(3), np.zeros((3, 3)), B, a, A)
    kf.update(z)
    # slide 6:10: N(x|a,A) N(x|z,B) ~ N(x | B(A+B)^-1 a + A(A+B)^-1 z, A(A+B)^-1 B)
    S = np.linalg.inv(A + B)
    np.testing.assert_allclose(kf.x, B @ S @ a + A @ S @ z, atol=1e-12)
    np.testing.assert_allclose(kf.P, A @ S @ B, atol=1e-12)


@pytest.mark.parametrize("joseph", [True, False])
def test_kf_predict_update_matches_information_form(joseph):
    rng = np.random.default_rng(3)
    n, m = 4, 2
    F, H = rng.normal(size=(n, n)) * 0.5 + np.eye(n), rng.normal(size=(m, n))
    Q, R, P0 = random_spd(rng, n, 0.1), random_spd(rng, m, 0.3), random_spd(rng, n)
    x0 = rng.normal(size=n)
    kf = KalmanFilter(F, H, Q, R, x0, P0, options=KalmanFilterOptions(joseph_form=joseph))
    x, P = x0, P0
    for _ in range(10):
        z = rng.normal(size=m)
        kf.predict()
        # slide 6:10 propagation: N(x | F b, Q + F B F^T)
        x, P = F @ x, Q + F @ P @ F.T
        np.testing.assert_allclose(kf.P, P, rtol=1e-10, atol=1e-10)
        kf.update(z)
        x, P = info_form_update(x, P, z, H, R)
        np.testing.assert_allclose(kf.x, x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(kf.P, P, rtol=1e-9, atol=1e-9)


def test_kf_control_input_and_dead_reckoning():
    F, Q, H = constant_velocity_model(0.1, 0.2)
    B = np.vstack([0.005 * np.eye(2), 0.1 * np.eye(2)])
    kf = KalmanFilter(F, H, Q, 0.1 * np.eye(2), np.zeros(4), np.eye(4), B=B)
    us = np.ones((5, 2))
    res = kf.run([None] * 5, controls=us)
    x, P = np.zeros(4), np.eye(4)
    for u in us:
        x, P = F @ x + B @ u, F @ P @ F.T + Q
    np.testing.assert_allclose(res.means[-1], x, atol=1e-12)
    np.testing.assert_allclose(res.covs[-1], P, atol=1e-12)
    assert res.num_updates == 0 and np.isnan(res.nis).all()
    # dead reckoning: uncertainty only grows (slide 7:17)
    assert np.all(np.diff(np.trace(res.covs, axis1=1, axis2=2)) > 0)


def test_constant_velocity_fast_filter_matches_reference():
    rng = np.random.default_rng(4)
    dt = 0.05
    F, Q, H = constant_velocity_model(dt, 0.7)
    R = np.array([[0.2, 0.05], [0.05, 0.1]])
    P0 = random_spd(rng, 4)
    x0 = rng.normal(size=4)
    cv = ConstantVelocityKalmanFilter(dt, Q, R, x0, P0)
    x, P = x0, P0
    for z in rng.normal(size=(30, 2)):
        cv.step(z)
        x, P = F @ x, F @ P @ F.T + Q
        x, P = info_form_update(x, P, z, H, R)
    np.testing.assert_allclose(cv.x, x, atol=1e-10)
    np.testing.assert_allclose(cv.P, P, atol=1e-10)


def test_constant_velocity_model_matches_integrated_white_noise():
    # Q = int_0^dt e^{As} G q G^T e^{A^T s} ds for the continuous CV model (Van Loan reference)
    dt, q = 0.3, 2.0
    F, Q, H = constant_velocity_model(dt, q)
    A = np.zeros((4, 4))
    A[0, 2] = A[1, 3] = 1.0
    Gq = np.diag([0, 0, q, q])
    M = np.block([[-A, Gq], [np.zeros((4, 4)), A.T]]) * dt
    E = scipy.linalg.expm(M)
    Phi = E[4:, 4:].T
    np.testing.assert_allclose(F, Phi, atol=1e-12)
    np.testing.assert_allclose(Q, Phi @ E[:4, 4:], atol=1e-12)
    np.testing.assert_array_equal(H, np.hstack([np.eye(2), np.zeros((2, 2))]))


@pytest.mark.parametrize("m", [1, 2, 3])
def test_batch_kf_matches_per_track_reference(m):
    rng = np.random.default_rng(5 + m)
    N, n = 7, 4
    F, Q, _ = constant_velocity_model(0.1, 0.5)
    H = rng.normal(size=(m, n))
    R = random_spd(rng, m, 0.2)
    x0 = rng.normal(size=(N, n))
    P0 = np.stack([random_spd(rng, n) for _ in range(N)])
    bkf = BatchKalmanFilter(F, H, Q, R, x0, P0)
    xs, Ps = list(x0), list(P0)
    for _ in range(6):
        z = rng.normal(size=(N, m))
        nis = bkf.step(z)
        for i in range(N):
            xp, Pp = F @ xs[i], F @ Ps[i] @ F.T + Q
            r = z[i] - H @ xp
            S = H @ Pp @ H.T + R
            assert nis[i] == pytest.approx(r @ np.linalg.solve(S, r), rel=1e-9)
            xs[i], Ps[i] = info_form_update(xp, Pp, z[i], H, R)
    np.testing.assert_allclose(bkf.x, np.array(xs), atol=1e-9)
    np.testing.assert_allclose(bkf.P, np.array(Ps), atol=1e-9)


# ---------------------------------------------------------------- EKF / UKF on linear models


def _linear_problem(seed: int):
    rng = np.random.default_rng(seed)
    F, Q, H = constant_velocity_model(0.1, 0.5)
    R = np.diag([0.3, 0.2])
    x0, P0 = rng.normal(size=4), random_spd(rng, 4)
    zs = rng.normal(size=(15, 2))
    return F, Q, H, R, x0, P0, zs


def test_ekf_equals_kf_on_linear_model():
    F, Q, H, R, x0, P0, zs = _linear_problem(6)
    kf = KalmanFilter(F, H, Q, R, x0, P0).run(zs)
    ekf = ExtendedKalmanFilter(
        lambda x, u: F @ x, lambda x, u: F, lambda x: H @ x, lambda x: H, Q, R, x0, P0
    ).run(list(zs))
    np.testing.assert_allclose(ekf.means, kf.means, atol=1e-12)
    np.testing.assert_allclose(ekf.covs, kf.covs, atol=1e-12)
    assert ekf.log_likelihood == pytest.approx(kf.log_likelihood, rel=1e-12)


def test_ukf_is_exact_on_linear_model():
    F, Q, H, R, x0, P0, zs = _linear_problem(7)
    kf = KalmanFilter(F, H, Q, R, x0, P0).run(zs)
    ukf = UnscentedKalmanFilter(lambda x, u: F @ x, lambda x: H @ x, Q, R, x0, P0).run(list(zs))
    np.testing.assert_allclose(ukf.means, kf.means, atol=1e-10)
    np.testing.assert_allclose(ukf.covs, kf.covs, atol=1e-10)
    np.testing.assert_allclose(ukf.transition_jacobians[3], F, atol=1e-9)


def test_ukf_beats_ekf_mean_on_strong_nonlinearity():
    # x ~ N(0, 1), y = x^2: true E[y] = 1; the EKF linearization at 0 predicts 0.
    f = lambda x, u: x**2  # noqa: E731
    ukf = UnscentedKalmanFilter(f, lambda x: x, [[1e-9]], [[1.0]], [0.0], [[1.0]])
    ukf.predict()
    assert ukf.x[0] == pytest.approx(1.0, abs=1e-9)
    ekf = ExtendedKalmanFilter(
        f,
        lambda x, u: 2 * x[None, :],
        lambda x: x,
        lambda x: np.eye(1),
        [[1e-9]],
        [[1.0]],
        [0.0],
        [[1.0]],
    )
    ekf.predict()
    assert ekf.x[0] == pytest.approx(0.0)


# ---------------------------------------------------------------- RTS smoother


def test_rts_smoother_equals_batch_least_squares():
    F, Q, H, R, x0, P0, zs = _linear_problem(8)
    T, n, m = zs.shape[0], 4, 2
    res = KalmanFilter(F, H, Q, R, x0, P0).run(zs)
    sm = rts_smooth(res)
    # Batch weighted least squares over X = (x_-1, x_0, ..., x_{T-1}):
    # prior x_-1 ~ N(x0, P0); x_k - F x_{k-1} ~ N(0, Q); z_k - H x_k ~ N(0, R).
    N = (T + 1) * n
    rows, rhs, wts = [], [], []

    def add(Arow, b, W):
        rows.append(Arow)
        rhs.append(b)
        wts.append(np.linalg.cholesky(np.linalg.inv(W)).T)

    A0 = np.zeros((n, N))
    A0[:, :n] = np.eye(n)
    add(A0, x0, P0)
    for k in range(T):
        Ad = np.zeros((n, N))
        Ad[:, (k + 1) * n : (k + 2) * n] = np.eye(n)
        Ad[:, k * n : (k + 1) * n] = -F
        add(Ad, np.zeros(n), Q)
        Am = np.zeros((m, N))
        Am[:, (k + 1) * n : (k + 2) * n] = H
        add(Am, zs[k], R)
    Aw = np.vstack([W @ A for W, A in zip(wts, rows)])
    bw = np.concatenate([W @ b for W, b in zip(wts, rhs)])
    X = np.linalg.lstsq(Aw, bw, rcond=None)[0].reshape(T + 1, n)
    cov = np.linalg.inv(Aw.T @ Aw)
    np.testing.assert_allclose(sm.means, X[1:], atol=1e-9)
    for k in range(T):
        blk = cov[(k + 1) * n : (k + 2) * n, (k + 1) * n : (k + 2) * n]
        np.testing.assert_allclose(sm.covs[k], blk, atol=1e-9)
    # the last smoothed belief is the filtered one
    np.testing.assert_allclose(sm.means[-1], res.means[-1])


# ---------------------------------------------------------------- consistency


def test_nees_and_nis_within_chi2_bounds_over_monte_carlo_runs():
    rng = np.random.default_rng(9)
    F, Q, H = constant_velocity_model(0.1, 1.0)
    R = np.diag([0.05, 0.08])
    M, T = 60, 40
    LQ, LR = np.linalg.cholesky(Q), np.linalg.cholesky(R)
    P0 = np.eye(4)
    e = np.empty((M, T))
    nis = np.empty((M, T))
    for j in range(M):
        x = rng.multivariate_normal(np.zeros(4), P0)
        truth, zs = [], []
        for _ in range(T):
            x = F @ x + LQ @ rng.normal(size=4)
            truth.append(x)
            zs.append(H @ x + LR @ rng.normal(size=2))
        res = KalmanFilter(F, H, Q, R, np.zeros(4), P0).run(np.array(zs))
        e[j] = nees(np.array(truth), res.means, res.covs)
        nis[j] = res.nis
    lo, hi = chi2_bounds(4, M, 0.95)
    frac = np.mean((e.mean(0) >= lo) & (e.mean(0) <= hi))
    assert frac >= 0.85
    lo_all, hi_all = chi2_bounds(4, M * T, 0.99)
    assert lo_all <= e.mean() <= hi_all
    lo_z, hi_z = chi2_bounds(2, M * T, 0.99)
    assert lo_z <= nis.mean() <= hi_z
    # an overconfident filter (R too small) fails the same test
    res_bad = KalmanFilter(F, H, Q * 0.01, R * 0.01, np.zeros(4), P0).run(np.array(zs))
    assert nees(np.array(truth), res_bad.means, res_bad.covs).mean() > hi


# ---------------------------------------------------------------- error paths


def test_kf_errors_have_clear_messages():
    F, Q, H = constant_velocity_model(0.1, 0.5)
    with pytest.raises(ShapeError, match=r"H must have shape \(-1, 4\), got \(2, 3\)"):
        KalmanFilter(F, H[:, :3], Q, np.eye(2), np.zeros(4), np.eye(4))
    with pytest.raises(InvalidInputError, match="Q must be positive semi-definite; smallest"):
        KalmanFilter(F, H, -Q, np.eye(2), np.zeros(4), np.eye(4))
    with pytest.raises(InvalidInputError, match="R must be a symmetric covariance"):
        KalmanFilter(F, H, Q, [[1.0, 0.5], [0.0, 1.0]], np.zeros(4), np.eye(4))
    kf = KalmanFilter(F, H, Q, np.eye(2), np.zeros(4), np.eye(4))
    with pytest.raises(
        NotFiniteError, match=r"z has non-finite \(NaN or inf\) entries at indices \[1\]"
    ):
        kf.update([0.0, np.nan])
    with pytest.raises(ShapeError, match=r"z must have shape \(2,\), got \(3,\)"):
        kf.update([0.0, 1.0, 2.0])
    with pytest.raises(InvalidInputError, match="no B matrix"):
        kf.predict(u=[1.0])
    with pytest.raises(NotFiniteError, match="measurements"):
        kf.run(np.array([[0.0, 0.0], [np.inf, 0.0]]))


def test_fast_and_batch_filter_errors():
    F, Q, H = constant_velocity_model(0.1, 0.5)
    cv = ConstantVelocityKalmanFilter(0.1, Q, np.eye(2), np.zeros(4), np.eye(4))
    with pytest.raises(NotFiniteError, match=r"z has non-finite.*\[0\]"):
        cv.step([np.nan, 0.0])
    with pytest.raises(InvalidInputError, match="R must be positive definite"):
        ConstantVelocityKalmanFilter(0.1, Q, np.zeros((2, 2)), np.zeros(4), np.eye(4))
    with pytest.raises(InvalidInputError, match="dt must be finite and > 0"):
        ConstantVelocityKalmanFilter(0.0, Q, np.eye(2), np.zeros(4), np.eye(4))
    b = BatchKalmanFilter(F, H, Q, np.eye(2), np.zeros((3, 4)), np.eye(4))
    with pytest.raises(ShapeError, match=r"z must have shape \(3, 2\), got \(2, 2\)"):
        b.update(np.zeros((2, 2)))
    with pytest.raises(NotFiniteError, match=r"indices \[2\]"):
        b.update(np.array([[0, 0], [0, 0], [np.nan, 0]]))
    with pytest.raises(ShapeError, match="P0"):
        BatchKalmanFilter(F, H, Q, np.eye(2), np.zeros((3, 4)), np.zeros((2, 4, 4)))
    with pytest.raises(TaskspaceError):
        nees(np.zeros((3, 4)), np.zeros((3, 4)), np.zeros((3, 4, 4)))
    with pytest.raises(InvalidInputError, match="dof >= 1"):
        chi2_bounds(0)
