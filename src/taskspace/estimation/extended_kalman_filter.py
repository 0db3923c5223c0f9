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

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.filter_result import FilterResult
from taskspace.estimation.kalman_filter import (
    KalmanFilterOptions,
    _finish,
    kalman_update,
)

StateFn = Callable[[FloatArray, Any], FloatArray]
MeasFn = Callable[[FloatArray], FloatArray]
Residual = Callable[[FloatArray, FloatArray], FloatArray]


def _subtract(a: FloatArray, b: FloatArray) -> FloatArray:
    return a - b


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
        self.x = as_vector(x0, None, "x0")
        n = self.x.shape[0]
        self.P = as_covariance(P0, n, "P0")
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_covariance(R, None, "R", positive_definite=True)
        self.f, self.F_jacobian, self.h, self.H_jacobian = f, F_jacobian, h, H_jacobian
        self.residual = residual or _subtract
        self.state_normalize = state_normalize
        self.options = options or KalmanFilterOptions()
        self.dim_x = n
        self.dim_z = self.R.shape[0]
        self._last_F = np.eye(n)
        self._last_ll = 0.0

    def predict(self, u: Any = None) -> None:
        """``x = f(x, u)``, ``P = F P F^T + Q`` with ``F = df/dx`` at the prior mean."""
        n = self.dim_x
        F = np.asarray(self.F_jacobian(self.x, u), dtype=np.float64)
        if F.shape != (n, n):
            raise ShapeError("F_jacobian output", (n, n), tuple(F.shape))
        x = np.asarray(self.f(self.x, u), dtype=np.float64)
        if x.shape != (n,):
            raise ShapeError("f output", (n,), tuple(x.shape))
        if self.state_normalize is not None:
            x = self.state_normalize(x)
        P = F @ self.P @ F.T + self.Q
        self.x, self.P, self._last_F = x, 0.5 * (P + P.T), F

    def update(self, z: Any) -> float:
        """Condition on ``z`` with ``H = dh/dx`` at the predicted mean; returns the NIS."""
        zv = as_vector(z, self.dim_z, "z")
        H = np.asarray(self.H_jacobian(self.x), dtype=np.float64)
        if H.shape != (self.dim_z, self.dim_x):
            raise ShapeError("H_jacobian output", (self.dim_z, self.dim_x), tuple(H.shape))
        r = np.asarray(self.residual(zv, np.asarray(self.h(self.x), dtype=np.float64)))
        self.x, self.P, nis, self._last_ll = kalman_update(
            self.x, self.P, r, H, self.R, joseph_form=self.options.joseph_form
        )
        if self.state_normalize is not None:
            self.x = self.state_normalize(self.x)
        return nis

    def run(
        self, measurements: Sequence[Any | None], controls: Sequence[Any] | None = None
    ) -> FilterResult:
        """For each ``k``: predict with ``controls[k]`` then update with ``measurements[k]``.

        ``None`` measurements skip the update. Returns the :class:`FilterResult` whose
        ``transition_jacobians`` feed the RTS smoother.
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
            self.predict(None if controls is None else controls[k])
            pm[k], pc[k], Fs[k] = self.x, self.P, self._last_F
            if measurements[k] is not None:
                nis[k] = self.update(measurements[k])
                ll += self._last_ll
                updates += 1
            means[k], covs[k] = self.x, self.P
        return _finish(means, covs, pm, pc, Fs, nis, ll, updates, t0, self.options.check_psd)
