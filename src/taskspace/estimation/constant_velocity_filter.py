"""Hand-specialized Kalman filter for the 2-D constant-velocity model (slides 7:6, 7:26).

State ``x = (p_x, p_y, v_x, v_y)`` [m, m, m/s, m/s], transition ``F = [[I, dt I], [0, I]]``,
measurement of the position ``z = H x + v`` with ``H = [I 0]``. Writing the general equations
of :mod:`taskspace.estimation.kalman_filter` out on the 10 unique entries of the symmetric ``P``
removes every matrix product, allocation and numpy call from the step:

* predict: ``P^- = F P F^T + Q`` is ``A' = A + dt (B + B^T) + dt^2 C``, ``B' = B + dt C``,
  ``C' = C`` on the blocks ``P = [[A, B], [B^T, C]]``, plus ``Q``;
* update: ``S = A' + R`` (2 x 2, closed-form inverse), ``K = P^-[:, :2] S^-1``,
  ``x = x^- + K (z - p^-)``, ``P = P^- - K P^-[:2, :]``.

A predict+update costs a few microseconds in CPython, an order of magnitude below a generic
numpy implementation.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_vector, check_count, check_positive
from taskspace.errors import InvalidInputError, NotFiniteError, SolverError
from taskspace.estimation._serialized import serialized
from taskspace.estimation.covariance import as_covariance

_IDX = ((0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3))


def constant_velocity_model(
    dt: float, accel_noise: float, dim: int = 2
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Discrete constant-velocity model driven by white-noise acceleration.

    ``F = [[I, dt I], [0, I]]``, ``Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]``, ``H = [I 0]``.

    Args:
        dt: time step [s].
        accel_noise: spectral density ``q`` of the acceleration noise [m^2/s^3].
        dim: spatial dimension (state has ``2 dim`` entries).

    Returns:
        ``(F, Q, H)``.
    """
    dt = check_positive(dt, "dt")
    q = check_positive(accel_noise, "accel_noise", strict=False)
    dim = check_count(dim, "dim", minimum=1)
    eye = np.eye(dim)
    F = np.block([[eye, dt * eye], [np.zeros((dim, dim)), eye]])
    with np.errstate(over="ignore", invalid="ignore"):  # dt**3 overflowed (bare OverflowError)
        d = np.float64(dt)
        Q = q * np.block([[d**3 / 3 * eye, d**2 / 2 * eye], [d**2 / 2 * eye, d * eye]])
    if not np.isfinite(Q).all():
        raise InvalidInputError(
            f"the process noise Q overflows for dt = {dt:g} s and accel_noise = {q:g}: rescale "
            "the time or the noise units"
        )
    H = np.hstack([eye, np.zeros((dim, dim))])
    return F, Q, H


class ConstantVelocityKalmanFilter:
    """Fast Kalman filter for the 2-D constant-velocity model with position measurements.

    Same posterior as :class:`~taskspace.estimation.KalmanFilter` with ``F, Q, H`` of
    :func:`constant_velocity_model` (short-form covariance update, symmetric by construction).

    Args:
        dt: time step [s].
        Q: ``(4, 4)`` process noise covariance [m^2, m^2/s, m^2/s^2].
        R: ``(2, 2)`` position measurement noise covariance [m^2].
        x0: ``(4,)`` prior mean ``(p_x, p_y, v_x, v_y)``.
        P0: ``(4, 4)`` prior covariance.

    Thread safety: calls are serialized by the filter's lock; each of ``set_belief``,
    ``predict``, ``update``, ``step`` is atomic, so threads sharing one filter (a sensor
    callback updating while a timer predicts) lose no update; they do not run in parallel (use
    one filter per thread for that). Read the belief between calls, not during another thread's
    update.
    """

    __slots__ = ("_dt", "_lock", "_p", "_q", "_r", "_x")

    def __init__(self, dt: float, Q: Any, R: Any, x0: Any, P0: Any) -> None:
        self._lock = threading.Lock()
        self._dt = check_positive(dt, "dt")
        Qm = as_covariance(Q, 4, "Q")
        Rm = as_covariance(R, 2, "R", positive_definite=True)
        self._q = tuple(float(Qm[i, j]) for i, j in _IDX)
        self._r = (float(Rm[0, 0]), float(Rm[0, 1]), float(Rm[1, 1]))
        self._x: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._p: tuple[float, ...] = ()
        self.set_belief(x0, P0)

    @serialized
    def set_belief(self, x: Any, P: Any) -> None:
        """Replace the belief by ``N(x, P)``."""
        xv = as_vector(x, 4, "x")
        Pm = as_covariance(P, 4, "P")
        self._x = (float(xv[0]), float(xv[1]), float(xv[2]), float(xv[3]))
        self._p = tuple(float(Pm[i, j]) for i, j in _IDX)

    @property
    def x(self) -> FloatArray:
        """Current mean ``(p_x, p_y, v_x, v_y)`` (a new array)."""
        return np.array(self._x)

    @property
    def P(self) -> FloatArray:
        """Current ``(4, 4)`` covariance (a new array)."""
        out = np.empty((4, 4))
        for v, (i, j) in zip(self._p, _IDX):
            out[i, j] = out[j, i] = v
        return out

    def predict(self) -> None:
        """Propagate one step: ``x = F x``, ``P = F P F^T + Q`` (slide 6:10 propagation)."""
        with self._lock:
            self._predict()

    def _predict(self) -> None:
        dt = self._dt
        x0, x1, x2, x3 = self._x
        p00, p01, p02, p03, p11, p12, p13, p22, p23, p33 = self._p
        q = self._q
        n02 = p02 + dt * p22
        n03 = p03 + dt * p23
        n12 = p12 + dt * p23
        n13 = p13 + dt * p33
        self._x = (x0 + dt * x2, x1 + dt * x3, x2, x3)
        self._p = (
            p00 + dt * (p02 + n02) + q[0],
            p01 + dt * (p12 + n03) + q[1],
            n02 + q[2],
            n03 + q[3],
            p11 + dt * (p13 + n13) + q[4],
            n12 + q[5],
            n13 + q[6],
            p22 + q[7],
            p23 + q[8],
            p33 + q[9],
        )

    def update(self, z: Any) -> None:
        """Condition on a position measurement ``z = (p_x, p_y)`` [m] (slide 6:10 product).

        Raises:
            NotFiniteError: if ``z`` has NaN or inf entries.
            SolverError: if the innovation covariance is singular.
        """
        with self._lock:
            self._update(z)

    def _update(self, z: Any) -> None:
        z0, z1 = z
        z0 = float(z0)
        z1 = float(z1)
        if not (math.isfinite(z0) and math.isfinite(z1)):
            raise NotFiniteError("z", [i for i, v in enumerate((z0, z1)) if not math.isfinite(v)])
        x0, x1, x2, x3 = self._x
        p00, p01, p02, p03, p11, p12, p13, p22, p23, p33 = self._p
        r00, r01, r11 = self._r
        s00 = p00 + r00
        s01 = p01 + r01
        s11 = p11 + r11
        det = s00 * s11 - s01 * s01
        if not det > 0.0:
            raise SolverError(f"innovation covariance is not positive definite (det = {det})")
        inv = 1.0 / det
        i00 = s11 * inv
        i01 = -s01 * inv
        i11 = s00 * inv
        k00 = p00 * i00 + p01 * i01
        k01 = p00 * i01 + p01 * i11
        k10 = p01 * i00 + p11 * i01
        k11 = p01 * i01 + p11 * i11
        k20 = p02 * i00 + p12 * i01
        k21 = p02 * i01 + p12 * i11
        k30 = p03 * i00 + p13 * i01
        k31 = p03 * i01 + p13 * i11
        y0 = z0 - x0
        y1 = z1 - x1
        self._x = (
            x0 + k00 * y0 + k01 * y1,
            x1 + k10 * y0 + k11 * y1,
            x2 + k20 * y0 + k21 * y1,
            x3 + k30 * y0 + k31 * y1,
        )
        self._p = (
            p00 - (k00 * p00 + k01 * p01),
            p01 - (k00 * p01 + k01 * p11),
            p02 - (k00 * p02 + k01 * p12),
            p03 - (k00 * p03 + k01 * p13),
            p11 - (k10 * p01 + k11 * p11),
            p12 - (k10 * p02 + k11 * p12),
            p13 - (k10 * p03 + k11 * p13),
            p22 - (k20 * p02 + k21 * p12),
            p23 - (k20 * p03 + k21 * p13),
            p33 - (k30 * p03 + k31 * p13),
        )

    def step(self, z: Any) -> None:
        """One predict + update with position measurement ``z`` [m] (fused, same equations)."""
        with self._lock:  # one acquisition (a plain Lock: ~0.1 us)
            self._predict()
            self._update(z)
