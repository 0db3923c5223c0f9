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
)
from taskspace.estimation._serialized import serialized
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.filter_result import FilterResult, FilterStatus

logger = logging.getLogger(__name__)

_LOG_2PI = math.log(2.0 * math.pi)
_CANCELLED = 1e-8
"""Posterior/prior variance ratio below which a short-form update is redone in Joseph form."""
_LOST = 1e-24
"""Posterior/prior variance ratio below which even the Joseph form is refused."""


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
    x: FloatArray,
    P: FloatArray,
    F: FloatArray,
    Q: FloatArray,
    Bu: FloatArray | None = None,
    *,
    step: str = "prediction",
) -> tuple[FloatArray, FloatArray]:
    """Kalman prediction ``x^- = F x + B u``, ``P^- = F P F^T + Q`` (propagation, slide 6:10).

    No validation of the inputs: this is the inner-loop kernel; :class:`KalmanFilter`
    validates them. ``step`` names the step in the error.

    Raises:
        SolverError: the predicted mean or covariance overflows the floats (e.g. ``F = 1e200
            I``); the message names which and the largest entries of what made it.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        return _predict(x, P, F, Q, Bu, step)


def _predict(
    x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray, Bu: FloatArray | None, step: str
) -> tuple[FloatArray, FloatArray]:
    """:func:`kalman_predict` under the caller's ``np.errstate(over=, invalid="ignore")``."""
    xp = F @ x
    if Bu is not None:
        xp = xp + Bu
    FPFQ = F @ P @ F.T + Q
    Pp = 0.5 * (FPFQ + FPFQ.T)
    if not _finite(xp, Pp):
        Pp = _halves(FPFQ)
        if not _finite(xp):
            sizes = {"F": F, "x": x} if Bu is None else {"F": F, "x": x, "B u": Bu}
            raise _overflow(step, "the mean F x + B u", sizes)
        if not _finite(Pp):
            raise _overflow(step, "the covariance F P F^T + Q", {"F": F, "P": P, "Q": Q})
    return xp, Pp


def propagate_covariance(F: FloatArray, P: FloatArray, Q: FloatArray, step: str) -> FloatArray:
    """``F P F^T + Q``, symmetrized (the prediction's covariance, slide 6:10).

    Raises:
        SolverError: it overflows the floats (``step`` names the step in the message).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        FPFQ = F @ P @ F.T + Q
        Pp = 0.5 * (FPFQ + FPFQ.T)
        if not _finite(Pp):
            Pp = _halves(FPFQ)
            if not _finite(Pp):
                raise _overflow(step, "the covariance F P F^T + Q", {"F": F, "P": P, "Q": Q})
    return Pp


def _halves(A: FloatArray) -> FloatArray:
    """``A / 2 + A^T / 2``: the symmetric part when ``A + A^T`` overflows (entries > 9e307)."""
    return 0.5 * A + 0.5 * A.T


def _finite(a: FloatArray, b: FloatArray | None = None) -> bool:
    """Whether every entry of ``a`` (and ``b``) is finite.

    The sums of squares first (one dot product each; a huge finite entry may overflow them,
    the exact test then decides); call under ``np.errstate(over="ignore")``.
    """
    total = float(np.vdot(a, a)) if b is None else float(np.vdot(a, a)) + float(np.vdot(b, b))
    if math.isfinite(total):
        return True
    return bool(np.isfinite(a).all()) and (b is None or bool(np.isfinite(b).all()))


def _overflow(step: str, what: str, sizes: dict[str, FloatArray]) -> SolverError:
    """The error of a step whose ``what`` is not finite, with the largest entries of ``sizes``."""
    with np.errstate(invalid="ignore"):
        largest = ", ".join(
            f"{name} {float(np.max(np.abs(a), initial=0.0)):.3g}" for name, a in sizes.items()
        )
    return SolverError(
        f"the {step} overflowed: {what} is not finite (largest entries: {largest}); the "
        "belief is left unchanged; rescale the states and measurements (units) or check "
        "the model"
    )


def kalman_update(
    x: FloatArray,
    P: FloatArray,
    residual: FloatArray,
    H: FloatArray,
    R: FloatArray,
    *,
    joseph_form: bool = True,
    step: str = "update",
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
        step: the step's name in errors.

    Returns:
        Updated mean, updated covariance, NIS ``r^T S^-1 r`` and ``log N(r | 0, S)``. A NIS
        beyond the floats (a residual some 1e154 standard deviations off) is ``inf`` and the
        log-likelihood ``-inf``: the update itself is exact, any gate refuses it.

    Raises:
        SolverError: if the innovation covariance ``S`` is not positive definite, or the
            residual, ``S``, the updated mean or covariance overflows the floats (the
            message names which and the largest entries of what made it; an ``S`` of inf
            entries gave a zero gain: the measurement was ignored, with NIS 0).
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _update(x, P, residual, H, R, joseph_form, step)


def _update(
    x: FloatArray,
    P: FloatArray,
    residual: FloatArray,
    H: FloatArray,
    R: FloatArray,
    joseph_form: bool,
    step: str,
) -> tuple[FloatArray, FloatArray, float, float]:
    """:func:`kalman_update` under the caller's ``np.errstate`` (over, invalid, divide ignored)."""
    PHt = P @ H.T
    S = H @ PHt + R
    if not _finite(residual, S):
        if not _finite(residual):
            raise _overflow(step, "the residual r = z - H x", {"x": x, "H": H})
        raise _overflow(step, "the innovation covariance S = H P H^T + R", {"H": H, "P": P, "R": R})
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError as exc:
        raise SolverError(f"innovation covariance S is not positive definite: {exc}") from exc
    # K^T = S^-1 (H P): two triangular solves via the Cholesky factor.
    Kt = np.linalg.solve(L.T, np.linalg.solve(L, PHt.T))
    K = Kt.T
    w = np.linalg.solve(L, residual)
    nis = float(np.vdot(w, w))  # (inf beyond the floats)
    loglik = -0.5 * nis - float(np.sum(np.log(np.diag(L)))) - 0.5 * residual.shape[0] * _LOG_2PI
    xn = x + K @ residual
    if joseph_form:
        IKH = np.eye(x.shape[0]) - K @ H
        Pu = IKH @ P @ IKH.T + K @ R @ Kt
    else:
        Pu = P - K @ S @ Kt
    Pn = 0.5 * (Pu + Pu.T)
    if math.isnan(nis) or not _finite(xn, Pn):
        Pn = _halves(Pu)
        if math.isnan(nis):
            raise _overflow(step, "the NIS r^T S^-1 r", {"r": residual, "S": S})
        if not _finite(xn):
            raise _overflow(step, "the updated mean x + K r", {"x": x, "K": K, "r": residual})
        if not _finite(Pn):
            raise _overflow(step, "the updated covariance", {"P": P, "K": K, "R": R})
    n = x.shape[0]
    prior, post = P.ravel()[:: n + 1], Pn.ravel()[:: n + 1]
    if not joseph_form and (post < _CANCELLED * prior).any():
        # P - K S K^T cancels when the measurement dominates the prior (P = 1e16 R gave
        # variances 0, 1e30 R gave -5.6e14): the Joseph form keeps K R K^T
        IKH = np.eye(n) - K @ H
        Pu = IKH @ P @ IKH.T + K @ R @ Kt
        Pn = 0.5 * (Pu + Pu.T)
        if not _finite(Pn):
            Pn = _halves(Pu)
            if not _finite(Pn):
                raise _overflow(step, "the updated covariance", {"P": P, "K": K, "R": R})
        post = Pn.ravel()[:: n + 1]
    _check_digits(step, prior, post)
    return xn, Pn, nis, loglik


def _check_digits(step: str, prior: FloatArray, post: FloatArray) -> None:
    """Refuse an update whose variances ``post`` lost every digit of ``prior`` (diagonals).

    Raises:
        SolverError: ``post < 1e-24 prior`` somewhere: ``(I - K H)`` is known to eps, its
            square to eps^2 of the prior.
    """
    lost = post < _LOST * prior
    if lost.any():  # (I - K H) is known to eps: its square to eps^2 of the prior
        which = np.flatnonzero(lost)[:20].tolist()
        raise SolverError(
            f"the {step} loses every digit of the covariance: the measurement is more than "
            f"1e12 times more precise than the predicted variances of x{which} (up to "
            f"{float(prior[lost].max()):.3g}; P = 1e30 R gave 1.05 R instead of R); the "
            "belief is left unchanged; rescale the states and measurements (units) or lower "
            "the prior/process variances"
        )


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

        Raises:
            SolverError: the predicted mean or covariance overflows the floats (named in
                the message; the belief is left unchanged).
        """
        uv = None
        if u is not None:
            if self.B is None:
                raise InvalidInputError("a control u was given but the filter has no B matrix")
            uv = as_measurement(u, self.B.shape[1], "u")
        with np.errstate(over="ignore", invalid="ignore"):  # (overflows: named by _predict)
            Bu = None if uv is None or self.B is None else self.B @ uv
            self.x, self.P = _predict(self.x, self.P, self.F, self.Q, Bu, "prediction")

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
            The normalized innovation squared ``r^T S^-1 r`` (NaN without a measurement,
            ``inf`` beyond the floats).

        Raises:
            SolverError: ``S`` is not positive definite, or the residual, ``S``, the updated
                mean or covariance overflows the floats (named in the message; the belief is
                left unchanged).
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
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            # (overflows, of the residual too: named by _update)
            x, P, nis, _ = _update(
                self.x, self.P, zv - Hm @ self.x, Hm, Rm, self.options.joseph_form, "update"
            )
        self.x, self.P = x, P
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

        Raises:
            SolverError: a step overflowed (the message names the step ``k`` and what
                overflowed); the filter keeps the belief of the step before.
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
        joseph = self.options.joseph_form
        # one errstate for the loop (no user code runs in it): the steps name their overflows
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            for k, z in enumerate(zs):
                Bu = None if us is None or self.B is None else self.B @ us[k]
                step = f"prediction of step {k}"
                self.x, self.P = _predict(self.x, self.P, self.F, self.Q, Bu, step)
                pm[k], pc[k] = self.x, self.P
                if z is not None:
                    r = z - self.H @ self.x
                    step = f"update of step {k}"
                    self.x, self.P, nis[k], ll = _update(
                        self.x, self.P, r, self.H, self.R, joseph, step
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
