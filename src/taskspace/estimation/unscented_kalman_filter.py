"""Unscented Kalman filter with scaled sigma points (Julier & Uhlmann; van der Merwe).

The Gaussian belief ``N(x, P)`` is represented by ``2n + 1`` sigma points
``chi_0 = x``, ``chi_{+-i} = x +- [sqrt((n + lambda) P)]_i`` with
``lambda = alpha^2 (n + kappa) - n`` and weights ``W^m_0 = lambda / (n + lambda)``,
``W^c_0 = W^m_0 + 1 - alpha^2 + beta``, ``W_i = 1 / (2 (n + lambda))``. Propagating them through
``f`` and ``h`` and re-fitting a Gaussian replaces the Jacobians of the EKF:

* predict: ``x^- = sum W^m_i f(chi_i)``, ``P^- = sum W^c_i d_i d_i^T + Q``;
* update: ``z_hat = sum W^m_i h(chi_i)``, ``S = sum W^c_i e_i e_i^T + R``,
  ``C = sum W^c_i d_i e_i^T``, ``K = C S^-1``, ``x = x^- + K (z - z_hat)``, ``P = P^- - K S K^T``.

For linear ``f`` and ``h`` the unscented transform is exact: the UKF equals the Kalman filter.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError, ShapeError, SolverError
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.filter_result import FilterResult
from taskspace.estimation.kalman_filter import _finish

StateFn = Callable[[FloatArray, Any], FloatArray]
MeasFn = Callable[[FloatArray], FloatArray]
Residual = Callable[[FloatArray, FloatArray], FloatArray]


@dataclass(frozen=True, kw_only=True)
class UnscentedOptions:
    """Sigma-point parameters of :class:`UnscentedKalmanFilter`.

    Attributes:
        alpha: spread of the sigma points (``0 < alpha <= 1``).
        beta: prior knowledge of the distribution (2 is optimal for Gaussians).
        kappa: secondary scaling.
    """

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0


def sigma_points(
    x: FloatArray, P: FloatArray, options: UnscentedOptions
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Scaled sigma points and weights (module docstring).

    Returns:
        ``(2n+1, n)`` points, ``(2n+1,)`` mean weights, ``(2n+1,)`` covariance weights.
    """
    n = x.shape[0]
    lam = options.alpha**2 * (n + options.kappa) - n
    if n + lam <= 0.0:
        raise InvalidInputError(f"n + lambda must be > 0 (n={n}, lambda={lam}); raise alpha/kappa")
    try:
        L = np.linalg.cholesky((n + lam) * P)
    except np.linalg.LinAlgError:
        # PSD but singular covariance: symmetric square root from the eigendecomposition.
        w, V = np.linalg.eigh((n + lam) * P)
        if w[0] < -1e-9 * max(1.0, abs(w[-1])):
            raise SolverError(f"covariance is not PSD (eigenvalue {w[0]:.3g})") from None
        L = V * np.sqrt(np.maximum(w, 0.0))
    pts = np.vstack([x, x + L.T, x - L.T])
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = wm[0] + 1.0 - options.alpha**2 + options.beta
    return pts, wm, wc


class UnscentedKalmanFilter:
    """Unscented Kalman filter (equations in the module docstring).

    Args:
        f: transition ``f(x, u) -> (n,)`` applied to each sigma point.
        h: measurement ``h(x) -> (m,)``.
        Q: ``(n, n)`` process noise covariance.
        R: ``(m, m)`` measurement noise covariance.
        x0: ``(n,)`` prior mean.
        P0: ``(n, n)`` prior covariance.
        residual: ``residual(z, z_hat)`` for measurement differences (default subtraction).
        options: sigma-point parameters.
    """

    def __init__(
        self,
        f: StateFn,
        h: MeasFn,
        Q: Any,
        R: Any,
        x0: Any,
        P0: Any,
        *,
        residual: Residual | None = None,
        options: UnscentedOptions | None = None,
    ) -> None:
        self.x = as_vector(x0, None, "x0")
        n = self.x.shape[0]
        self.P = as_covariance(P0, n, "P0")
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_covariance(R, None, "R", positive_definite=True)
        self.f, self.h = f, h
        self.residual = residual or (lambda a, b: a - b)
        self.options = options or UnscentedOptions()
        self.dim_x = n
        self.dim_z = self.R.shape[0]
        self._last_ll = 0.0

    def predict(self, u: Any = None) -> None:
        """Unscented prediction ``x^- = sum W^m f(chi)``, ``P^- = sum W^c d d^T + Q``."""
        n = self.dim_x
        pts, wm, wc = sigma_points(self.x, self.P, self.options)
        Y = np.array([np.asarray(self.f(p, u), dtype=np.float64) for p in pts])
        if Y.shape != (2 * n + 1, n):
            raise ShapeError("f output", (n,), tuple(Y.shape[1:]))
        x = wm @ Y
        D = Y - x
        P = (D * wc[:, None]).T @ D + self.Q
        self.x, self.P = x, 0.5 * (P + P.T)

    def update(self, z: Any) -> float:
        """Unscented update; returns the NIS ``r^T S^-1 r``."""
        m = self.dim_z
        zv = as_vector(z, m, "z")
        pts, wm, wc = sigma_points(self.x, self.P, self.options)
        Z = np.array([np.asarray(self.h(p), dtype=np.float64) for p in pts])
        if Z.shape != (pts.shape[0], m):
            raise ShapeError("h output", (m,), tuple(Z.shape[1:]))
        zhat = wm @ Z
        E = np.array([self.residual(zi, zhat) for zi in Z])
        D = pts - self.x
        S = (E * wc[:, None]).T @ E + self.R
        C = (D * wc[:, None]).T @ E
        try:
            L = np.linalg.cholesky(0.5 * (S + S.T))
        except np.linalg.LinAlgError as exc:
            raise SolverError(f"innovation covariance S is not positive definite: {exc}") from exc
        r = np.asarray(self.residual(zv, zhat), dtype=np.float64)
        Kt = np.linalg.solve(L.T, np.linalg.solve(L, C.T))
        w = np.linalg.solve(L, r)
        nis = float(w @ w)
        self._last_ll = (
            -0.5 * nis - float(np.sum(np.log(np.diag(L)))) - 0.5 * m * math.log(2 * math.pi)
        )
        self.x = self.x + Kt.T @ r
        P = self.P - Kt.T @ S @ Kt
        self.P = 0.5 * (P + P.T)
        return nis

    def run(
        self, measurements: Sequence[Any | None], controls: Sequence[Any] | None = None
    ) -> FilterResult:
        """Predict/update over a sequence (``None`` measurements skip the update).

        ``transition_jacobians`` of the result hold the statistical linearization
        ``F_k = C_k^T P_{k-1}^-1`` (cross-covariance of prior and predicted sigma points).
        """
        t0 = time.perf_counter()
        T = len(measurements)
        if controls is not None and len(controls) != T:
            raise InvalidInputError(
                f"controls must have one entry per measurement ({T}), got {len(controls)}"
            )
        n = self.dim_x
        means = np.empty((T, n))
        covs = np.empty((T, n, n))
        pm = np.empty((T, n))
        pc = np.empty((T, n, n))
        Fs = np.empty((T, n, n))
        nis = np.full(T, np.nan)
        ll = 0.0
        updates = 0
        for k in range(T):
            u = None if controls is None else controls[k]
            pts, wm, wc = sigma_points(self.x, self.P, self.options)
            Y = np.array([np.asarray(self.f(p, u), dtype=np.float64) for p in pts])
            Cxy = ((pts - self.x) * wc[:, None]).T @ (Y - wm @ Y)
            Fs[k] = np.linalg.lstsq(self.P, Cxy, rcond=None)[0].T
            self.predict(u)
            pm[k], pc[k] = self.x, self.P
            if measurements[k] is not None:
                nis[k] = self.update(measurements[k])
                ll += self._last_ll
                updates += 1
            means[k], covs[k] = self.x, self.P
        return _finish(means, covs, pm, pc, Fs, nis, ll, updates, t0, False)
