"""Linear Kalman filter: Bayes filtering with Gaussians (slides 6:10, 7:20, 7:26).

Model: ``x_k = F x_{k-1} + B u_{k-1} + w``, ``w ~ N(0, Q)`` and ``z_k = H x_k + v``,
``v ~ N(0, R)``. The two steps are the propagation and product identities of slide 6:10:

* predict: ``x^- = F x + B u``, ``P^- = F P F^T + Q``
* update: ``S = H P^- H^T + R``, ``K = P^- H^T S^-1``, ``x = x^- + K (z - H x^-)`` and either the
  Joseph form ``P = (I - K H) P^- (I - K H)^T + K R K^T`` (default, stays PSD under round-off)
  or the short form ``P = P^- - K S K^T``.

Thread safety: :class:`KalmanFilter` serializes its calls with a lock (see there);
:class:`KalmanFilterOptions` is immutable; the functions keep their state local to the call.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_matrix
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, SolverError
from taskspace.estimation._inputs import (
    as_measurement,
    as_noise_covariance,
    as_state,
    checked_belief,
)
from taskspace.estimation._serialized import serialized
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.filter_result import FilterResult, FilterStatus

logger = logging.getLogger(__name__)

_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True, kw_only=True)
class KalmanFilterOptions:
    """Settings of the Kalman-family filters.

    Attributes:
        joseph_form: use the Joseph-form covariance update (numerically PSD).
        check_psd: after each run, verify every covariance is PSD (costs one eigvalsh per step).
    """

    joseph_form: bool = True
    check_psd: bool = False


def kalman_predict(
    x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray, Bu: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Kalman prediction ``x^- = F x + B u``, ``P^- = F P F^T + Q`` (propagation, slide 6:10).

    No validation: this is the inner-loop kernel; :class:`KalmanFilter` validates inputs.
    """
    xp = F @ x
    if Bu is not None:
        xp = xp + Bu
    Pp = F @ P @ F.T + Q
    return xp, 0.5 * (Pp + Pp.T)


def kalman_update(
    x: FloatArray,
    P: FloatArray,
    residual: FloatArray,
    H: FloatArray,
    R: FloatArray,
    *,
    joseph_form: bool = True,
) -> tuple[FloatArray, FloatArray, float, float]:
    """Kalman measurement update (Gaussian product, slide 6:10).

    ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x+ = x + K r``; covariance by the Joseph form
    ``(I - K H) P (I - K H)^T + K R K^T`` or by ``P - K S K^T``.

    Args:
        x: ``(n,)`` predicted mean.
        P: ``(n, n)`` predicted covariance.
        residual: ``(m,)`` innovation ``r = z - h(x)``.
        H: ``(m, n)`` measurement matrix (Jacobian).
        R: ``(m, m)`` measurement noise covariance.
        joseph_form: choose the covariance update.

    Returns:
        Updated mean, updated covariance, NIS ``r^T S^-1 r`` and ``log N(r | 0, S)``.

    Raises:
        SolverError: if the innovation covariance ``S`` is not positive definite.
    """
    PHt = P @ H.T
    S = H @ PHt + R
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError as exc:
        raise SolverError(f"innovation covariance S is not positive definite: {exc}") from exc
    # K^T = S^-1 (H P): two triangular solves via the Cholesky factor.
    Kt = np.linalg.solve(L.T, np.linalg.solve(L, PHt.T))
    K = Kt.T
    w = np.linalg.solve(L, residual)
    nis = float(w @ w)
    loglik = -0.5 * nis - float(np.sum(np.log(np.diag(L)))) - 0.5 * residual.shape[0] * _LOG_2PI
    xn = x + K @ residual
    if joseph_form:
        IKH = np.eye(x.shape[0]) - K @ H
        Pn = IKH @ P @ IKH.T + K @ R @ Kt
    else:
        Pn = P - K @ S @ Kt
    return xn, 0.5 * (Pn + Pn.T), nis, loglik


class KalmanFilter:
    """Linear Kalman filter with a validated model and an internal belief ``(x, P)``.

    Equations in the module docstring (slides 6:10, 7:26). For the 2-D constant-velocity model at
    maximum speed use :class:`~taskspace.estimation.ConstantVelocityKalmanFilter`; for many
    tracks at once use :class:`~taskspace.estimation.BatchKalmanFilter`.

    Args:
        F: ``(n, n)`` state transition matrix.
        H: ``(m, n)`` measurement matrix.
        Q: ``(n, n)`` process noise covariance.
        R: ``(m, m)`` measurement noise covariance (positive definite).
        x0: ``(n,)`` prior mean.
        P0: ``(n, n)`` prior covariance.
        B: optional ``(n, p)`` control matrix.
        options: filter settings.

    Thread safety: calls are serialized by the filter's lock; each of ``predict``, ``update``,
    ``run`` is atomic, so threads sharing one filter (a sensor callback updating while a timer
    predicts) lose no update; they do not run in parallel (use one filter per thread for that).
    Read the belief between calls, not during another thread's update.
    """

    def __init__(
        self,
        F: Any,
        H: Any,
        Q: Any,
        R: Any,
        x0: Any,
        P0: Any,
        *,
        B: Any | None = None,
        options: KalmanFilterOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.F = as_matrix(F, (None, None), "F")
        n = self.F.shape[0]
        if self.F.shape[1] != n:
            raise InvalidInputError(f"F must be square, got shape {self.F.shape}")
        self.H = as_matrix(H, (None, n), "H")
        m = self.H.shape[0]
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_noise_covariance(R, m, "R")
        self.B = None if B is None else as_matrix(B, (n, None), "B")
        if options is not None and not isinstance(options, KalmanFilterOptions):
            raise InvalidInputError(
                f"options must be a KalmanFilterOptions, got {type(options).__name__}"
            )
        self.options = options or KalmanFilterOptions()
        self.x = as_state(x0, n, "x0")
        self.P = as_covariance(P0, n, "P0")
        self.dim_x = n
        self.dim_z = m

    @serialized
    def predict(self, u: Any | None = None) -> None:
        """Propagate the belief one step: ``x = F x + B u``, ``P = F P F^T + Q``.

        Args:
            u: optional ``(p,)`` control (requires ``B``); a scalar or a column ``(p, 1)``
                is accepted.
        """
        Bu = None
        if u is not None:
            if self.B is None:
                raise InvalidInputError("a control u was given but the filter has no B matrix")
            Bu = self.B @ as_measurement(u, self.B.shape[1], "u")
        self.x, self.P = checked_belief(
            *kalman_predict(self.x, self.P, self.F, self.Q, Bu), "prediction"
        )

    @serialized
    def update(self, z: Any, R: Any | None = None, H: Any | None = None) -> float:
        """Condition the belief on a measurement ``z`` (product identity, slide 6:10).

        Args:
            z: ``(m,)`` measurement, a column ``(m, 1)``, a scalar when ``m == 1``, or
                ``None`` (no measurement: the belief is left unchanged, NIS is NaN).
            R: noise covariance of this measurement only (``(m, m)``, or a scalar ``r``
                for ``r I``); default the filter's ``R``.
            H: measurement matrix of this measurement only (``(m', n)``; then ``z`` has
                ``m'`` entries and ``R`` must be given when ``m' != m``); default the
                filter's ``H``.

        Returns:
            The normalized innovation squared ``r^T S^-1 r`` (NaN without a measurement).
        """
        if z is None:
            return math.nan
        Hm = self.H if H is None else as_matrix(H, (None, self.dim_x), "H")
        m = Hm.shape[0]
        if R is None:
            if m != self.dim_z:
                raise InvalidInputError(
                    f"this H has {m} rows but the filter's R is {self.dim_z} x {self.dim_z}: pass "
                    "the noise covariance R of this measurement too"
                )
            Rm = self.R
        else:
            Rm = as_noise_covariance(R, m, "R")
        zv = as_measurement(z, m, "z")
        x, P, nis, _ = kalman_update(
            self.x,
            self.P,
            zv - Hm @ self.x,
            Hm,
            Rm,
            joseph_form=self.options.joseph_form,
        )
        self.x, self.P = checked_belief(x, P, "update")
        return nis

    @serialized
    def run(
        self, measurements: Sequence[Any | None] | FloatArray, controls: Any | None = None
    ) -> FilterResult:
        """Filter a whole sequence: for each ``k`` predict, then update with ``z_k``.

        Args:
            measurements: ``(T, m)`` array or a length-``T`` sequence whose entries may be
                ``None`` (no measurement at that step: predict only, i.e. dead reckoning).
            controls: optional ``(T, p)`` controls ``u_{k-1}`` applied in the prediction of step k.

        Returns:
            The :class:`FilterResult` (the filter keeps the last belief).
        """
        t0 = time.perf_counter()
        zs = _as_measurement_list(measurements, self.dim_z)
        T = len(zs)
        us = None
        if controls is not None:
            if self.B is None:
                raise InvalidInputError("controls were given but the filter has no B matrix")
            us = as_matrix(controls, (T, self.B.shape[1]), "controls")
        n = self.dim_x
        means = np.empty((T, n))
        covs = np.empty((T, n, n))
        pm = np.empty((T, n))
        pc = np.empty((T, n, n))
        nis = np.full(T, np.nan)
        loglik = 0.0
        updates = 0
        for k, z in enumerate(zs):
            Bu = None if us is None or self.B is None else self.B @ us[k]
            self.x, self.P = kalman_predict(self.x, self.P, self.F, self.Q, Bu)
            pm[k], pc[k] = self.x, self.P
            if z is not None:
                self.x, self.P, nis[k], ll = kalman_update(
                    self.x,
                    self.P,
                    z - self.H @ self.x,
                    self.H,
                    self.R,
                    joseph_form=self.options.joseph_form,
                )
                loglik += ll
                updates += 1
            means[k], covs[k] = self.x, self.P
        return _finish(
            means,
            covs,
            pm,
            pc,
            np.broadcast_to(self.F, (T, n, n)).copy(),
            nis,
            loglik,
            updates,
            t0,
            self.options.check_psd,
        )


def _as_measurement_list(measurements: Any, m: int) -> list[FloatArray | None]:
    """Validate a measurement sequence; ``None`` entries mean 'no measurement'."""
    if isinstance(measurements, np.ndarray) and measurements.dtype != object:
        arr = as_float_array(measurements, "measurements")
        if arr.ndim == 1 and m == 1:
            arr = arr[:, None]
        if arr.ndim == 3 and arr.shape[2] == 1:  # a sequence of columns
            arr = arr[:, :, 0]
        if arr.ndim != 2 or arr.shape[1] != m:
            raise ShapeError("measurements", (-1, m), tuple(arr.shape))
        if not np.all(np.isfinite(arr)):
            bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
            raise NotFiniteError("measurements", [int(i) for i in bad[:20]])
        return list(arr)
    if isinstance(measurements, (str, bytes)) or not isinstance(measurements, Iterable):
        raise InvalidInputError(
            "measurements must be a (T, m) array or a sequence of measurements (or None), got "
            f"{type(measurements).__name__}"
        )
    out: list[FloatArray | None] = []
    for k, z in enumerate(measurements):
        out.append(None if z is None else as_measurement(z, m, f"measurements[{k}]"))
    return out


def _finish(
    means: FloatArray,
    covs: FloatArray,
    pm: FloatArray,
    pc: FloatArray,
    Fs: FloatArray,
    nis: FloatArray,
    loglik: float,
    updates: int,
    t0: float,
    check_psd: bool,
) -> FilterResult:
    """Assemble a :class:`FilterResult` and diagnose numerical failure."""
    ok = bool(np.all(np.isfinite(means)) and np.all(np.isfinite(covs)))
    message = "" if ok else "non-finite mean or covariance"
    if ok and check_psd and covs.size:
        lam = np.linalg.eigvalsh(covs)[:, 0]
        scale = np.maximum(1.0, np.abs(covs).max(axis=(1, 2)))
        bad = np.flatnonzero(lam < -1e-9 * scale)
        if bad.size:
            ok = False
            message = f"covariance lost positive semi-definiteness at steps {bad[:10].tolist()}"
    if not ok:
        logger.warning("filter run failed: %s", message)
    return FilterResult(
        success=ok,
        status=FilterStatus.SUCCESS if ok else FilterStatus.NUMERICAL_FAILURE,
        means=means,
        covs=covs,
        predicted_means=pm,
        predicted_covs=pc,
        transition_jacobians=Fs,
        nis=nis,
        log_likelihood=float(loglik),
        num_updates=updates,
        time_s=time.perf_counter() - t0,
        message=message,
    )
