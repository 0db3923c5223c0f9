"""The linear inverted pendulum / cart-table model of walking (Kajita et al. 2003).

A point mass at constant height ``z_c`` above flat ground: the ZMP ``p`` of each horizontal
axis is

    p = c - z_c / g * cddot,                                   (cart-table)

equivalently ``cddot = g / z_c (c - p)`` (inverted pendulum). With the CoM jerk ``u`` as input
and ``x = (c, cdot, cddot)``, the exact discretization with step ``dt`` is

    x_{k+1} = A x_k + B u_k,   p_k = C x_k,
    A = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]],   B = [dt^3/6, dt^2/2, dt],
    C = [1, 0, -z_c / g].

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray, as_scalar, check_positive
from taskspace.errors import InvalidInputError

MAX_SAMPLES = 1_000_000
"""Most samples of a walking pattern (the MPC solves one QP per sample)."""


@dataclass(frozen=True, kw_only=True)
class CartTable:
    """Cart-table model of one horizontal axis (both axes use the same matrices).

    Attributes:
        com_height: ``z_c`` [m].
        dt: sampling period [s].
        gravity: ``g`` [m/s^2].
    """

    com_height: float = 0.8
    dt: float = 0.005
    gravity: float = 9.81

    def __post_init__(self) -> None:
        check_positive(self.com_height, "com_height")
        check_positive(self.dt, "dt")
        check_positive(self.gravity, "gravity")

    def sample_times(self, duration: float) -> FloatArray:
        """``0, dt, 2 dt, ...`` covering ``duration`` [s] (at most :data:`MAX_SAMPLES` samples).

        Raises:
            InvalidInputError: the duration is not a finite number ``>= 0``, or it needs more
                than :data:`MAX_SAMPLES` samples of ``dt``.
        """
        duration = as_scalar(duration, "duration [s]")
        if duration < 0.0:
            raise InvalidInputError(f"duration must be a number of seconds >= 0, got {duration!r}")
        n = float(np.ceil(duration / self.dt)) + 1
        if not n <= MAX_SAMPLES:
            raise InvalidInputError(
                f"a {duration:g} s walk sampled every dt = {self.dt:g} s has {n:.3g} samples "
                f"(at most {MAX_SAMPLES}): use a larger dt"
            )
        return np.arange(int(n), dtype=np.float64) * self.dt

    @property
    def A(self) -> FloatArray:
        """(3, 3) state transition."""
        dt = self.dt
        return np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])

    @property
    def B(self) -> FloatArray:
        """(3, 1) jerk input."""
        dt = self.dt
        return np.array([[dt**3 / 6], [dt * dt / 2], [dt]])

    @property
    def C(self) -> FloatArray:
        """(1, 3) ZMP output."""
        return np.array([[1.0, 0.0, -self.com_height / self.gravity]])

    @property
    def omega(self) -> float:
        """Natural frequency ``sqrt(g / z_c)`` of the pendulum [1/s]."""
        return float(np.sqrt(self.gravity / self.com_height))

    def zmp(self, state: FloatArray) -> FloatArray:
        """ZMP of states ``(..., 3)`` (or (3, axes)): ``c - z_c / g cddot``."""
        return np.asarray(state[..., 0] - self.com_height / self.gravity * state[..., 2])


@dataclass(frozen=True)
class LipmTrajectory:
    """A sampled CoM / ZMP trajectory of the cart-table model (both horizontal axes).

    Attributes:
        times: (T,) sample times [s].
        com: (T, 2) CoM position [m].
        com_velocity: (T, 2) [m/s].
        com_acceleration: (T, 2) [m/s^2].
        zmp: (T, 2) ZMP of the model, ``c - z_c / g cddot`` [m].
        zmp_reference: (T, 2) the reference the controller tracked [m].
        jerk: (T, 2) the input applied at each sample [m/s^3].
        com_height: ``z_c`` [m].
    """

    times: FloatArray
    com: FloatArray
    com_velocity: FloatArray
    com_acceleration: FloatArray
    zmp: FloatArray
    zmp_reference: FloatArray
    jerk: FloatArray
    com_height: float

    @property
    def zmp_error(self) -> FloatArray:
        """(T,) distance between the ZMP and its reference [m]."""
        return np.asarray(np.linalg.norm(self.zmp - self.zmp_reference, axis=1))

    @property
    def rms_zmp_error(self) -> float:
        """Root mean square of :attr:`zmp_error` [m]."""
        return float(np.sqrt(np.mean(self.zmp_error**2)))
