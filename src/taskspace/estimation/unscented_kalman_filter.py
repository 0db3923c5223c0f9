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

Thread safety: :class:`UnscentedKalmanFilter` serializes its calls with a lock (see there);
:class:`UnscentedOptions` is immutable; :func:`sigma_points` keeps its state local to the call.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar
from taskspace.errors import InvalidInputError, SolverError
from taskspace.estimation._inputs import (
    as_measurement,
    as_noise_covariance,
    as_state,
    call_model,
    checked_belief,
    model_output,
)
from taskspace.estimation._serialized import serialized
from taskspace.estimation.angles import MeanFn, subtract, weighted_mean
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

    States or measurements holding angles need a residual and a mean that know the circle
    (:func:`~taskspace.estimation.angle_residual`, :func:`~taskspace.estimation.angle_mean`):
    with them ``d_i = residual_x(f(chi_i), x^-)``, ``e_i = residual(h(chi_i), z_hat)`` and the
    means are ``mean_x(Y, W^m)``, ``mean_z(Z, W^m)``.

    Args:
        f: transition ``f(x, u) -> (n,)`` applied to each sigma point.
        h: measurement ``h(x) -> (m,)``.
        Q: ``(n, n)`` process noise covariance.
        R: ``(m, m)`` measurement noise covariance.
        x0: ``(n,)`` prior mean.
        P0: ``(n, n)`` prior covariance.
        residual: ``residual(z, z_hat)`` for measurement differences (default subtraction).
        residual_x: ``residual_x(x, x_mean)`` for state differences (default subtraction).
        mean_x: ``mean_x(points (N, n), weights (N,)) -> (n,)`` (default weighted sum).
        mean_z: ``mean_z(points (N, m), weights (N,)) -> (m,)`` (default weighted sum).
        options: sigma-point parameters.

    User functions: an exception other than a ``TaskspaceError`` raised by one of them is
    re-raised as :class:`~taskspace.errors.CallbackError` naming it (the original is its
    ``__cause__``); what they return is checked (shape, finiteness) before it is used; the
    belief is left unchanged when a step fails.

    Thread safety: calls are serialized by the filter's lock; each of ``predict``, ``update``,
    ``run`` is atomic, so threads sharing one filter (a sensor callback updating while a timer
    predicts) lose no update; they do not run in parallel (use one filter per thread for that).
    Read the belief between calls, not during another thread's update.
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
        residual_x: Residual | None = None,
        mean_x: MeanFn | None = None,
        mean_z: MeanFn | None = None,
        options: UnscentedOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.x = as_state(x0, None, "x0")
        n = self.x.shape[0]
        self.P = as_covariance(P0, n, "P0")
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_noise_covariance(R, None, "R")
        for label, fn in (
            ("f", f),
            ("h", h),
            ("residual", residual),
            ("residual_x", residual_x),
            ("mean_x", mean_x),
            ("mean_z", mean_z),
        ):
            if fn is not None and not callable(fn):
                raise InvalidInputError(f"{label} must be a function, got {type(fn).__name__}")
        if options is not None and not isinstance(options, UnscentedOptions):
            raise InvalidInputError(
                f"options must be an UnscentedOptions, got {type(options).__name__}"
            )
        self.options = options or UnscentedOptions()
        for label, value in (
            ("alpha", self.options.alpha),
            ("beta", self.options.beta),
            ("kappa", self.options.kappa),
        ):
            as_scalar(value, f"UnscentedOptions.{label}")
        if not 0.0 < self.options.alpha <= 1.0:
            raise InvalidInputError(
                f"UnscentedOptions.alpha must be in (0, 1], got {self.options.alpha!r}"
            )
        self.f, self.h = f, h
        self.residual = residual or subtract
        self.residual_x = residual_x or subtract
        self.mean_x = mean_x or weighted_mean
        self.mean_z = mean_z or weighted_mean
        self.dim_x = n
        self.dim_z = self.R.shape[0]
        self._last_ll = 0.0

    def _propagate(self, pts: FloatArray, u: Any) -> FloatArray:
        """``f`` at every sigma point, checked (shape, finiteness)."""
        n = self.dim_x
        return np.array(
            [
                model_output(call_model(self.f, "f", p, u), (n,), f"f (sigma point {i})")
                for i, p in enumerate(pts)
            ]
        ).reshape(pts.shape[0], n)

    @serialized
    def predict(self, u: Any = None) -> None:
        """Unscented prediction ``x^- = mean_x(f(chi), W^m)``, ``P^- = sum W^c d d^T + Q``.

        Raises:
            ShapeError, InvalidInputError: ``f`` returned a wrong shape or non-finite values
                at a sigma point (the belief is left unchanged).
        """
        n = self.dim_x
        pts, wm, wc = sigma_points(self.x, self.P, self.options)
        Y = self._propagate(pts, u)
        x = model_output(call_model(self.mean_x, "mean_x", Y, wm), (n,), "mean_x")
        D = np.array(
            [
                model_output(call_model(self.residual_x, "residual_x", y, x), (n,), "residual_x")
                for y in Y
            ]
        ).reshape(Y.shape)
        P = (D * wc[:, None]).T @ D + self.Q
        self.x, self.P = checked_belief(x, 0.5 * (P + P.T), "prediction")

    @serialized
    def update(
        self,
        z: Any,
        R: Any | None = None,
        *,
        h: MeasFn | None = None,
        residual: Residual | None = None,
    ) -> float:
        """Unscented update; returns the NIS ``r^T S^-1 r``.

        Args:
            z: measurement ``(m,)``, a column ``(m, 1)``, a scalar when ``m == 1``, or
                ``None`` (no measurement: the belief is unchanged and the NIS is NaN).
            R: noise covariance of this measurement only (``(m, m)`` or a scalar ``r`` for
                ``r I``); required when ``h`` gives another size than the filter's ``R``.
            h: measurement function of this measurement only.
            residual: measurement residual of this measurement only.

        Raises:
            ShapeError, InvalidInputError: a wrong size, or ``h`` returned non-finite values
                (the belief is left unchanged).
            SolverError: the innovation covariance is not positive definite.
        """
        if z is None:
            return math.nan
        h_fn = self.h if h is None else h
        res_fn = self.residual if residual is None else residual
        pts, wm, wc = sigma_points(self.x, self.P, self.options)
        first = as_float_array(call_model(h_fn, "h", pts[0]), "h output")
        m = 1 if not np.shape(first) else int(np.shape(first)[0])
        if R is None:
            if m != self.dim_z:
                raise InvalidInputError(
                    f"h returns {m} values but the filter's R is {self.dim_z} x {self.dim_z}: "
                    "pass the noise covariance R of this measurement"
                )
            Rm = self.R
        else:
            Rm = as_noise_covariance(R, m, "R")
        zv = as_measurement(z, m, "z")
        rows = [model_output(first, (m,), "h (sigma point 0)")]
        rows += [
            model_output(call_model(h_fn, "h", p), (m,), f"h (sigma point {i})")
            for i, p in enumerate(pts)
            if i
        ]
        Z = np.array(rows).reshape(pts.shape[0], m)
        zhat = model_output(call_model(self.mean_z, "mean_z", Z, wm), (m,), "mean_z")
        E = np.array(
            [model_output(call_model(res_fn, "residual", zi, zhat), (m,), "residual") for zi in Z]
        ).reshape(Z.shape)
        D = np.array(
            [
                model_output(
                    call_model(self.residual_x, "residual_x", p, self.x),
                    (self.dim_x,),
                    "residual_x",
                )
                for p in pts
            ]
        ).reshape(pts.shape)
        S = (E * wc[:, None]).T @ E + Rm
        C = (D * wc[:, None]).T @ E
        try:
            L = np.linalg.cholesky(0.5 * (S + S.T))
        except np.linalg.LinAlgError as exc:
            raise SolverError(f"innovation covariance S is not positive definite: {exc}") from exc
        r = model_output(call_model(res_fn, "residual", zv, zhat), (m,), "residual")
        Kt = np.linalg.solve(L.T, np.linalg.solve(L, C.T))
        w = np.linalg.solve(L, r)
        nis = float(w @ w)
        last_ll = -0.5 * nis - float(np.sum(np.log(np.diag(L)))) - 0.5 * m * math.log(2 * math.pi)
        P = self.P - Kt.T @ S @ Kt
        self.x, self.P = checked_belief(self.x + Kt.T @ r, 0.5 * (P + P.T), "update")
        self._last_ll = last_ll
        return nis

    @serialized
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
            Y = self._propagate(pts, u)
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
