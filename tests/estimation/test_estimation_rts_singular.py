"""RTS smoothing when a predicted covariance is singular (a state known exactly).

A constant measurement bias with zero prior variance and no process noise makes every
predicted covariance singular; the smoother takes its pseudo-inverse. Reference: the exact
posterior of the joint Gaussian over all states (prior by stacking the dynamics, one
conditioning on all measurements), which needs no inverse of a state covariance.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.estimation import KalmanFilter
from taskspace.estimation.rts_smoother import rts_smooth

DT = 0.1
# position, velocity (a random walk), a constant bias added to the measured position
F = np.array([[1.0, DT, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
H = np.array([[1.0, 0.0, 1.0]])
R = np.array([[0.01]])
X0 = np.array([0.0, 1.0, 0.5])


def _measurements(T: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = X0 + np.array([rng.normal(), rng.normal(), 0.0])
    zs = []
    for _ in range(T):
        x = F @ x + np.array([0.01, 0.1, 0.0]) * rng.normal(size=3)
        zs.append(H @ x + 0.1 * rng.normal(size=1))
    return np.array(zs)


def _joint_posterior(
    Q: np.ndarray, P0: np.ndarray, zs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Means (T, n) and covariances (T, n, n) of x_0..x_{T-1} given every measurement."""
    T, n = zs.shape[0], F.shape[0]
    A = np.zeros((T * n, n))
    B = np.zeros((T * n, T * n))
    for k in range(T):
        A[k * n : (k + 1) * n] = np.linalg.matrix_power(F, k + 1)
        for j in range(k + 1):
            B[k * n : (k + 1) * n, j * n : (j + 1) * n] = np.linalg.matrix_power(F, k - j)
    mu = A @ X0
    S = A @ P0 @ A.T + B @ np.kron(np.eye(T), Q) @ B.T
    Hb, Rb = np.kron(np.eye(T), H), np.kron(np.eye(T), R)
    K = S @ Hb.T @ np.linalg.inv(Hb @ S @ Hb.T + Rb)
    mean = (mu + K @ (zs.ravel() - Hb @ mu)).reshape(T, n)
    cov = S - K @ Hb @ S
    return mean, np.array([cov[k * n : (k + 1) * n, k * n : (k + 1) * n] for k in range(T)])


@pytest.mark.parametrize("bias_variance", [0.0, 1e-30])
@pytest.mark.parametrize("seed", range(3))
def test_a_known_constant_is_smoothed_exactly(bias_variance: float, seed: int) -> None:
    Q = np.diag([1e-4, 1e-2, 0.0])
    P0 = np.diag([1.0, 1.0, bias_variance])
    zs = _measurements(20, seed)
    run = KalmanFilter(F, H, Q, R, X0, P0).run(zs)
    smooth = rts_smooth(run)
    mean, cov = _joint_posterior(Q, P0, zs)
    np.testing.assert_allclose(smooth.means, mean, atol=1e-10)
    np.testing.assert_allclose(smooth.covs, cov, atol=1e-10)
    # the bias stays what it was known to be, with no uncertainty
    np.testing.assert_allclose(smooth.means[:, 2], 0.5, atol=1e-12)
    assert np.abs(smooth.covs[:, 2, :]).max() < 1e-12


def test_a_regular_problem_gives_the_joint_posterior_too() -> None:
    Q = np.diag([1e-4, 1e-2, 1e-3])
    P0 = np.diag([1.0, 1.0, 0.2])
    zs = _measurements(15, 7)
    smooth = rts_smooth(KalmanFilter(F, H, Q, R, X0, P0).run(zs))
    mean, cov = _joint_posterior(Q, P0, zs)
    np.testing.assert_allclose(smooth.means, mean, atol=1e-9)
    np.testing.assert_allclose(smooth.covs, cov, atol=1e-9)
