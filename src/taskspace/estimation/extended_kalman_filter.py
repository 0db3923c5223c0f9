"""Extended Kalman filter (slide 7:26 with linearized models).

Model: ``x_k = f(x_{k-1}, u_{k-1}) + w``, ``w ~ N(0, Q)``; ``z_k = h(x_k) + v``, ``v ~ N(0, R)``.
The Kalman equations are applied to the first-order Taylor expansions with Jacobians
``F = df/dx`` and ``H = dh/dx`` at the current mean:

* predict: ``x^- = f(x, u)``, ``P^- = F P F^T + Q``;
* update: ``r = z (-) h(x^-)`` (``(-)`` is a user residual, e.g. with angle wrapping),
  ``S = H P^- H^T + R``, ``K = P^- H^T S^-1``, ``x = x^- + K r``, Joseph-form ``P``.

On a linear model (``f = F x + B u``, ``h = H x``) it is exactly the Kalman filter.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array
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
from taskspace.estimation.angles import subtract
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.filter_result import FilterResult
from taskspace.estimation.kalman_filter import (
    KalmanFilterOptions,
    _finish,
    _overflow,
    kalman_update,
    propagate_covariance,
)

StateFn = Callable[[FloatArray, Any], FloatArray]
MeasFn = Callable[[FloatArray], FloatArray]
Residual = Callable[[FloatArray, FloatArray], FloatArray]


def _length(value: Any) -> int:
    """Length of a model output (a vector, a column or a scalar)."""
    shape = np.shape(value)
    return 1 if not shape else int(shape[0])


class ExtendedKalmanFilter:
    """Extended Kalman filter with user-supplied models and analytic Jacobians.

    Args:
        f: transition ``f(x, u) -> (n,)``.
        F_jacobian: ``df/dx (x, u) -> (n, n)``.
        h: measurement function ``h(x) -> (m,)``.
        H_jacobian: ``dh/dx (x) -> (m, n)``.
        Q: ``(n, n)`` process noise covariance.
        R: ``(m, m)`` measurement noise covariance.
        x0: ``(n,)`` prior mean.
        P0: ``(n, n)`` prior covariance.
        residual: ``residual(z, z_hat) -> (m,)`` (default ``z - z_hat``; wrap bearings here).
        state_normalize: optional ``g(x) -> x`` applied after each step (e.g. wrap headings).
        options: filter settings.

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
        F_jacobian: StateFn,
        h: MeasFn,
        H_jacobian: MeasFn,
        Q: Any,
        R: Any,
        x0: Any,
        P0: Any,
        *,
        residual: Residual | None = None,
        state_normalize: Callable[[FloatArray], FloatArray] | None = None,
        options: KalmanFilterOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.x = as_state(x0, None, "x0")
        n = self.x.shape[0]
        self.P = as_covariance(P0, n, "P0")
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_noise_covariance(R, None, "R")
        for label, fn in (
            ("f", f),
            ("F_jacobian", F_jacobian),
            ("h", h),
            ("H_jacobian", H_jacobian),
            ("residual", residual),
            ("state_normalize", state_normalize),
        ):
            if fn is not None and not callable(fn):
                raise InvalidInputError(f"{label} must be a function, got {type(fn).__name__}")
        if options is not None and not isinstance(options, KalmanFilterOptions):
            raise InvalidInputError(
                f"options must be a KalmanFilterOptions, got {type(options).__name__}"
            )
        self.f, self.F_jacobian, self.h, self.H_jacobian = f, F_jacobian, h, H_jacobian
        self.residual = residual or subtract
        self.state_normalize = state_normalize
        self.options = options or KalmanFilterOptions()
        self.dim_x = n
        self.dim_z = self.R.shape[0]
        self._last_F = np.eye(n)
        self._last_ll = 0.0

    @serialized
    def predict(self, u: Any = None) -> None:
        """``x = f(x, u)``, ``P = F P F^T + Q`` with ``F = df/dx`` at the prior mean.

        Raises:
            ShapeError, InvalidInputError: ``f`` or ``F_jacobian`` returned a wrong shape or
                non-finite values (the belief is left unchanged).
            SolverError: ``F P F^T + Q`` overflows the floats (the belief is left unchanged).
        """
        n = self.dim_x
        F = model_output(call_model(self.F_jacobian, "F_jacobian", self.x, u), (n, n), "F_jacobian")
        x = model_output(call_model(self.f, "f", self.x, u), (n,), "f")
        if self.state_normalize is not None:
            x = model_output(
                call_model(self.state_normalize, "state_normalize", x), (n,), "state_normalize"
            )
        P = propagate_covariance(F, self.P, self.Q, "prediction")
        self.x, self.P = checked_belief(x, P, "prediction")
        self._last_F = F

    @serialized
    def update(
        self,
        z: Any,
        R: Any | None = None,
        *,
        h: MeasFn | None = None,
        H_jacobian: MeasFn | None = None,
        residual: Residual | None = None,
    ) -> float:
        """Condition on ``z`` with ``H = dh/dx`` at the predicted mean; returns the NIS.

        Args:
            z: measurement ``(m,)``, a column ``(m, 1)``, a scalar when ``m == 1``, or
                ``None`` (no measurement: the belief is unchanged and the NIS is NaN).
            R: noise covariance of this measurement only (``(m, m)`` or a scalar ``r`` for
                ``r I``); required when ``h`` gives another size than the filter's ``R``.
            h, H_jacobian: measurement model of this measurement only (both or neither);
                e.g. a second sensor.
            residual: ``residual(z, z_hat)`` of this measurement only (e.g. bearings:
                :func:`~taskspace.estimation.angle_residual`).

        Returns:
            The NIS ``r^T S^-1 r`` (``inf`` beyond the floats).

        Raises:
            ShapeError, InvalidInputError: a wrong size, or a model returned non-finite
                values (the belief is left unchanged).
            SolverError: ``S`` is not positive definite, or ``S``, the updated mean or
                covariance overflows the floats (named in the message; the belief is left
                unchanged).
        """
        if z is None:
            return math.nan
        if (h is None) != (H_jacobian is None):
            raise InvalidInputError("pass both h and H_jacobian for a per-call measurement model")
        h_fn = self.h if h is None else h
        H_fn = self.H_jacobian if H_jacobian is None else H_jacobian
        res_fn = self.residual if residual is None else residual
        raw = as_float_array(call_model(h_fn, "h", self.x), "h output")
        zhat = model_output(raw, (_length(raw),), "h")
        m = zhat.shape[0]
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
        H = model_output(call_model(H_fn, "H_jacobian", self.x), (m, self.dim_x), "H_jacobian")
        if res_fn is subtract:  # the default: an overflow is the update's, not a model's
            with np.errstate(over="ignore", invalid="ignore"):
                r = zv - zhat
            if not np.isfinite(r).all():
                raise _overflow("update", "the residual z - h(x)", {"z": zv, "h(x)": zhat})
        else:
            r = model_output(call_model(res_fn, "residual", zv, zhat), (m,), "residual")
        x, P, nis, ll = kalman_update(
            self.x, self.P, r, H, Rm, joseph_form=self.options.joseph_form
        )
        if self.state_normalize is not None:
            x = model_output(
                call_model(self.state_normalize, "state_normalize", x),
                (self.dim_x,),
                "state_normalize",
            )
        self.x, self.P = checked_belief(x, P, "update")
        self._last_ll = ll
        return nis

    @serialized
    def run(
        self, measurements: Sequence[Any | None], controls: Sequence[Any] | None = None
    ) -> FilterResult:
        """For each ``k``: predict with ``controls[k]`` then update with ``measurements[k]``.

        ``None`` measurements skip the update. Returns the :class:`FilterResult` whose
        ``transition_jacobians`` feed the RTS smoother.

        Raises:
            SolverError: a step overflowed (the message names the step ``k``); the filter
                keeps the belief of the step before.
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
            try:
                self.predict(None if controls is None else controls[k])
            except SolverError as exc:
                raise SolverError(f"step {k}: {exc}") from exc
            pm[k], pc[k], Fs[k] = self.x, self.P, self._last_F
            if measurements[k] is not None:
                try:
                    nis[k] = self.update(measurements[k])
                except SolverError as exc:
                    raise SolverError(f"step {k}: {exc}") from exc
                ll += self._last_ll
                updates += 1
            means[k], covs[k] = self.x, self.P
        return _finish(means, covs, pm, pc, Fs, nis, ll, updates, t0, self.options.check_psd)
