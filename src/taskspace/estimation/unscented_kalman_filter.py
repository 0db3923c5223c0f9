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
from taskspace.estimation.kalman_filter import (
    _CANCELLED,
    _check_digits,
    _finish,
    _finite,
    _halves,
    _overflow,
)

# largest relative error of a sigma point's offset x +- L_i from the mean (x + L rounds to
# eps |x|; 1e-4 keeps 4 digits of the square root: UTM northings 5e6 m need a std above 1e-5 m)
_SPREAD = 1e-4

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
    noise = np.zeros(n, dtype=bool)
    c = math.sqrt(n + lam)  # sqrt((n + lambda) P) = c sqrt(P): (n + lambda) P overflowed near 1e308
    try:
        L = c * np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        # PSD but singular covariance: symmetric square root from the eigendecomposition.
        w, V = np.linalg.eigh(P)
        if w[0] < -1e-9 * max(1.0, abs(w[-1])):
            raise SolverError(f"covariance is not PSD (eigenvalue {w[0]:.3g})") from None
        L = V * (c * np.sqrt(np.maximum(w, 0.0)))
        noise = w <= n * np.finfo(float).eps * abs(w[-1])  # (directions of a singular P)
    with np.errstate(over="ignore", invalid="ignore"):
        pts = np.vstack([x, x + L.T, x - L.T])
        if not _finite(pts):
            raise _overflow("sigma points", "x +- sqrt((n + lambda) P)", {"x": x, "P": P})
        # x + L rounds to x's precision: a spread below eps |x| is lost (x = 1e300 with
        # P = I kept every point at x: the covariance silently became Q, the gain 0)
        lost = np.abs((pts[1 : n + 1] - x) - L.T).max(axis=1, initial=0.0)
        spread = np.abs(L.T).max(axis=1, initial=0.0)
    bad = (lost > _SPREAD * spread) & ~noise
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SolverError(
            f"the sigma points x +- sqrt((n + lambda) P) lose the covariance: column {i} of the "
            f"square root (largest entry {float(spread[i]):.3g}) is below the precision of the "
            f"mean (largest entry {float(np.max(np.abs(x))):.3g}; relative error "
            f"{float(lost[i] / spread[i]):.3g}); shift the state origin or rescale the states"
        )
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
            SolverError: the sigma points lose the covariance (its square root below the
                precision of the mean) or the covariance overflows (the message names it).
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
        with np.errstate(over="ignore", invalid="ignore"):
            P = (D * wc[:, None]).T @ D + self.Q
            Ps = 0.5 * (P + P.T)
            if not _finite(Ps):
                Ps = _halves(P)
                if not _finite(Ps):
                    raise _overflow(
                        "prediction",
                        "the covariance sum W^c d d^T + Q",
                        {"P": self.P, "d": D, "Q": self.Q},
                    )
        self.x, self.P = checked_belief(x, Ps, "prediction")

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
            SolverError: the innovation covariance is not positive definite; the sigma points
                lose the covariance; ``S``, the cross covariance, the mean or the covariance
                overflow (the message names which); the update loses every digit of the
                covariance (variances below 1e-24 of the prior, as the Kalman filter's).
                The belief is left unchanged. Linear models give the Kalman filter's answer; the
                sigma-point mean of ``h`` carries an error near ``eps sqrt(S)``.
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
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            x, P, nis, last_ll = self._correct(D, E, wc, Rm, zv, zhat, res_fn)
        self.x, self.P = checked_belief(x, P, "update")
        self._last_ll = last_ll
        return nis

    def _correct(
        self,
        D: FloatArray,
        E: FloatArray,
        wc: FloatArray,
        Rm: FloatArray,
        zv: FloatArray,
        zhat: FloatArray,
        res_fn: Residual,
    ) -> tuple[FloatArray, FloatArray, float, float]:
        """The update from the sigma-point deviations ``D`` (state) and ``E`` (measurement).

        Under the caller's ``np.errstate``; every overflow raises a SolverError naming the
        quantity. ``P - K S K^T`` cancels when the measurement dominates the prior (P = 1e16 R
        gave variance 2 R instead of R): then the Joseph form ``(I - K H) P (I - K H)^T +
        K R' K^T`` with the statistical linearization ``H = C^T P^-1`` and
        ``R' = R + Lambda + H (P - P_sigma) H^T = S - H P H^T``, where
        ``Lambda = sum W^c (e - H d)(e - H d)^T`` is the linearization error and
        ``P_sigma = sum W^c d d^T`` (P for the default residual_x): the same matrix in
        exact arithmetic, without the cancellation. An update losing every digit (variances
        below 1e-24 of the prior) is refused as the Kalman filter's.
        """
        step = "update"
        m = E.shape[1]
        S = (E * wc[:, None]).T @ E + Rm
        C = (D * wc[:, None]).T @ E
        if not _finite(S, C):
            if not _finite(S):
                raise _overflow(
                    step,
                    "the innovation covariance S = sum W^c e e^T + R",
                    {"h(sigma) - z_hat": E, "R": Rm},
                )
            raise _overflow(
                step, "the cross covariance C = sum W^c d e^T", {"d": D, "h(sigma) - z_hat": E}
            )
        try:
            L = np.linalg.cholesky(0.5 * S + 0.5 * S.T)
        except np.linalg.LinAlgError as exc:
            raise SolverError(f"innovation covariance S is not positive definite: {exc}") from exc
        r = model_output(call_model(res_fn, "residual", zv, zhat), (m,), "residual")
        Kt = np.linalg.solve(L.T, np.linalg.solve(L, C.T))
        w = np.linalg.solve(L, r)
        nis = float(np.vdot(w, w))
        last_ll = -0.5 * nis - float(np.sum(np.log(np.diag(L)))) - 0.5 * m * math.log(2 * math.pi)
        x = self.x + Kt.T @ r
        if math.isnan(nis) or not _finite(x):
            raise _overflow(step, "the updated mean x + K r", {"x": self.x, "K": Kt, "r": r})
        Pu = self.P - Kt.T @ S @ Kt
        P = 0.5 * Pu + 0.5 * Pu.T
        n = self.dim_x
        prior, post = self.P.ravel()[:: n + 1], P.ravel()[:: n + 1]
        if (post < _CANCELLED * prior).any():
            H = np.linalg.lstsq(self.P, C, rcond=None)[0].T
            G = E - D @ H.T
            # R + Lambda + H (P - P_sigma) H^T = S - H P H^T; P_sigma = sum W^c d d^T is P
            # for the subtraction (the term, rounding of order eps P, is left out), not for
            # a wrapping residual_x
            Reff = Rm + (G * wc[:, None]).T @ G
            if self.residual_x is not subtract:
                Reff = Reff + H @ (self.P - (D * wc[:, None]).T @ D) @ H.T
            IKH = np.eye(n) - Kt.T @ H
            Pu = IKH @ self.P @ IKH.T + Kt.T @ Reff @ Kt
            P = 0.5 * Pu + 0.5 * Pu.T
            post = P.ravel()[:: n + 1]
        if not _finite(P):
            raise _overflow(step, "the updated covariance", {"P": self.P, "K": Kt, "R": Rm})
        _check_digits(step, prior, post)
        return x, P, nis, last_ll

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
            with np.errstate(over="ignore", invalid="ignore"):
                Cxy = ((pts - self.x) * wc[:, None]).T @ (Y - wm @ Y)
            x_prior, P_prior = self.x, self.P
            self.predict(u)  # (raises first when the prediction overflows)
            if not _finite(Cxy):
                self.x, self.P = x_prior, P_prior
                raise _overflow(
                    "prediction",
                    "the cross covariance sum W^c (chi - x)(f(chi) - x^-)^T of F_k",
                    {"P": P_prior, "f(chi)": Y},
                )
            Fs[k] = np.linalg.lstsq(P_prior, Cxy, rcond=None)[0].T
            pm[k], pc[k] = self.x, self.P
            if measurements[k] is not None:
                nis[k] = self.update(measurements[k])
                ll += self._last_ll
                updates += 1
            means[k], covs[k] = self.x, self.P
        return _finish(means, covs, pm, pc, Fs, nis, ll, updates, t0, False)
