"""Motion profiles for point-to-point interpolation (lecture slides 2:32-2:35).

A motion profile is a map ``MP: [0, 1] -> [0, 1]`` with ``MP(0) = 0`` and ``MP(1) = 1``
(slide 2:33). A point-to-point motion of duration ``T`` [s] from ``x0`` to ``xT`` is

    x(t) = x0 + MP(t / T) (xT - x0),                                   (slide 2:33)

so its physical derivatives are ``x^(k)(t) = (xT - x0) MP^(k)(t / T) / T^k``. The derivatives of
``MP`` with respect to the normalized time ``s`` are dimensionless; their peaks over ``[0, 1]``
determine the shortest duration that respects velocity, acceleration and jerk limits.

Profiles (normalized, ``s`` in ``[0, 1]``):

- ramp: ``MP(s) = s`` (slide 2:33); velocity jumps at both ends.
- sine: ``MP(s) = 1/2 (1 - cos(pi s))`` (slide 2:32); acceleration jumps at both ends.
- trapezoidal velocity: constant acceleration, cruise, constant deceleration; jerk is impulsive.
- minimum jerk: ``MP(s) = 10 s^3 - 15 s^4 + 6 s^5`` (zero velocity and acceleration at both
  ends; the minimizer of the integrated squared jerk).
- S-curve: 7 segments of constant jerk (+j, 0, -j, 0, -j, 0, +j); the time-optimal rest-to-rest
  motion under velocity, acceleration and jerk limits, including the degenerate cases where the
  maximum acceleration or the maximum velocity is not reached.

Multi-joint motions are synchronized so that every joint arrives at the same time
(:func:`synchronize`).

Thread safety: a profile is fixed at construction and not changed by sampling it (classes
without mutating methods; the samples and motions are immutable), so one profile may be sampled
from several threads; the functions keep their state local to the call.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, ClassVar

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    as_vector,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, ShapeError, UnknownNameError

__all__ = [
    "MinimumJerkProfile",
    "MotionProfile",
    "MotionSample",
    "PointToPointMotion",
    "RampProfile",
    "SCurveProfile",
    "SineProfile",
    "SyncMode",
    "SynchronizedMotion",
    "TrapezoidalProfile",
    "plan_motion",
    "profile_for_limits",
    "synchronize",
]

PROFILE_NAMES = ("ramp", "sine", "trapezoidal", "minimum_jerk", "scurve")


def _as_s(s: Any) -> FloatArray:
    """Normalized time as a float array clipped to ``[0, 1]``."""
    arr = as_float_array(s, "s")
    check_finite(arr, "s")
    return np.clip(arr, 0.0, 1.0)


def _check_order(order: Any) -> int:
    """``order`` as an int if it is a derivative order ``0..3``, else :class:`InvalidInputError`.

    (An order outside ``0..3`` was answered silently: the sine profile's jerk for ``-1``.)
    """
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or not 0 <= order <= 3:
        raise InvalidInputError(
            f"order must be an integer 0 (position), 1 (velocity), 2 (acceleration) or "
            f"3 (jerk), got {order!r}"
        )
    return int(order)


class MotionProfile(ABC):
    """A normalized motion profile ``MP: [0, 1] -> [0, 1]``, ``MP(0) = 0``, ``MP(1) = 1``.

    Derivatives are taken with respect to the normalized time ``s = t / T`` and are
    dimensionless. Inputs outside ``[0, 1]`` are clipped to the interval.
    """

    name: ClassVar[str] = ""

    @abstractmethod
    def derivative(self, s: Any, order: int = 0) -> FloatArray:
        """Return ``d^order MP / ds^order`` at ``s`` (order 0 to 3).

        Args:
            s: normalized time(s) in ``[0, 1]`` [-].
            order: derivative order (0 position, 1 velocity, 2 acceleration, 3 jerk).

        Returns:
            Array with the shape of ``s``.

        Raises:
            InvalidInputError: ``order`` is not an integer in ``0..3``.
        """

    @property
    @abstractmethod
    def peaks(self) -> tuple[float, float, float]:
        """``max |MP'|, max |MP''|, max |MP'''|`` over ``[0, 1]`` (``inf`` if impulsive)."""

    def position(self, s: Any) -> FloatArray:
        """``MP(s)`` [-]."""
        return self.derivative(s, 0)

    def velocity(self, s: Any) -> FloatArray:
        """``dMP/ds`` [-]."""
        return self.derivative(s, 1)

    def acceleration(self, s: Any) -> FloatArray:
        """``d^2 MP/ds^2`` [-]."""
        return self.derivative(s, 2)

    def jerk(self, s: Any) -> FloatArray:
        """``d^3 MP/ds^3`` [-] (zero inside segments of piecewise profiles)."""
        return self.derivative(s, 3)

    def min_duration(
        self,
        distance: float,
        max_velocity: float,
        max_acceleration: float | None = None,
        max_jerk: float | None = None,
    ) -> float:
        """Shortest duration ``T`` [s] for which this fixed shape respects the limits.

        ``T = max(d pv / v_max, sqrt(d pa / a_max), cbrt(d pj / j_max))`` with the peaks
        ``(pv, pa, pj)`` of ``MP', MP'', MP'''``. Limits whose peak is infinite (impulsive
        derivative) cannot be honored by this shape and are ignored.

        Args:
            distance: ``|xT - x0|`` [unit].
            max_velocity: velocity limit [unit/s].
            max_acceleration: acceleration limit [unit/s^2] or ``None``.
            max_jerk: jerk limit [unit/s^3] or ``None``.

        Returns:
            The duration [s] (0 for a zero distance).
        """
        d = abs(as_scalar(distance, "distance"))
        v = check_positive(max_velocity, "max_velocity")
        a = _check_limit(max_acceleration, "max_acceleration", False, self.name)
        j = _check_limit(max_jerk, "max_jerk", False, self.name)
        pv, pa, pj = self.peaks
        # ratios and roots taken separately so that no intermediate product over- or
        # underflows when the result is representable (d = 1e308, v = 1e308 gives T = 1.875)
        candidates = [(d / v) * pv]
        if a is not None and math.isfinite(pa):
            candidates.append(math.sqrt(d) * (math.sqrt(pa) / math.sqrt(a)))
        if j is not None and math.isfinite(pj):
            candidates.append(np.cbrt(d) * float(np.cbrt(pj) / np.cbrt(j)))
        return float(max(candidates))


class RampProfile(MotionProfile):
    """Linear profile ``MP(s) = s`` (slide 2:33); its acceleration is impulsive at the ends."""

    name = "ramp"

    def derivative(self, s: Any, order: int = 0) -> FloatArray:
        """``MP = s``, ``MP' = 1``, higher derivatives zero inside ``(0, 1)``."""
        s, order = _as_s(s), _check_order(order)
        if order == 0:
            return s.copy()
        if order == 1:
            return np.ones_like(s)
        return np.zeros_like(s)

    @property
    def peaks(self) -> tuple[float, float, float]:
        """``(1, inf, inf)``."""
        return (1.0, math.inf, math.inf)


class SineProfile(MotionProfile):
    """Sine profile ``MP(s) = 1/2 (1 - cos(pi s))`` (slide 2:32).

    ``MP' = pi/2 sin(pi s)``, ``MP'' = pi^2/2 cos(pi s)``, ``MP''' = -pi^3/2 sin(pi s)``; the
    acceleration starts at ``pi^2/2`` (a step from rest).
    """

    name = "sine"

    def derivative(self, s: Any, order: int = 0) -> FloatArray:
        """Derivatives of ``1/2 (1 - cos(pi s))``."""
        s, order = _as_s(s), _check_order(order)
        ps = np.pi * s
        if order == 0:
            return 0.5 * (1.0 - np.cos(ps))
        if order == 1:
            return 0.5 * np.pi * np.sin(ps)
        if order == 2:
            return 0.5 * np.pi**2 * np.cos(ps)
        return -0.5 * np.pi**3 * np.sin(ps)

    @property
    def peaks(self) -> tuple[float, float, float]:
        """``(pi/2, pi^2/2, pi^3/2)``."""
        return (0.5 * math.pi, 0.5 * math.pi**2, 0.5 * math.pi**3)


class MinimumJerkProfile(MotionProfile):
    """Minimum-jerk quintic ``MP(s) = 10 s^3 - 15 s^4 + 6 s^5``.

    Zero velocity and acceleration at both ends; peaks ``MP'(1/2) = 15/8``,
    ``|MP''| = 10/sqrt(3)`` at ``s = 1/2 -+ sqrt(3)/6`` and ``|MP'''| = 60`` at the ends.
    """

    name = "minimum_jerk"
    _COEFS: ClassVar[tuple[tuple[float, ...], ...]] = (
        (0.0, 0.0, 0.0, 10.0, -15.0, 6.0),
        (0.0, 0.0, 30.0, -60.0, 30.0),
        (0.0, 60.0, -180.0, 120.0),
        (60.0, -360.0, 360.0),
    )

    def derivative(self, s: Any, order: int = 0) -> FloatArray:
        """Derivatives of the quintic, evaluated by Horner's scheme."""
        s, order = _as_s(s), _check_order(order)
        out = np.zeros_like(s)
        for c in reversed(self._COEFS[order]):
            out = out * s + c
        return out

    @property
    def peaks(self) -> tuple[float, float, float]:
        """``(15/8, 10/sqrt(3), 60)``."""
        return (15.0 / 8.0, 10.0 / math.sqrt(3.0), 60.0)


class _PiecewiseProfile(MotionProfile):
    """Profile made of cubic pieces ``c0 + c1 u + c2 u^2 + c3 u^3`` in local time ``u``."""

    def __init__(
        self,
        durations: Sequence[float],
        jerks: Sequence[float],
        accels: Sequence[float] | None = None,
    ) -> None:
        # integrate the piecewise-constant jerk exactly from rest; ``accels`` (if given) sets the
        # acceleration at each segment start (piecewise-constant acceleration, zero jerk)
        breaks = np.concatenate(([0.0], np.cumsum(durations)))
        breaks[-1] = 1.0
        coefs = np.zeros((len(durations), 4))
        p = v = acc = 0.0
        for k, (h, j) in enumerate(zip(durations, jerks, strict=True)):
            if accels is not None:
                acc = accels[k]
            coefs[k] = (p, v, 0.5 * acc, j / 6.0)
            p, v, acc = (
                p + v * h + 0.5 * acc * h * h + j * h**3 / 6.0,
                v + acc * h + 0.5 * j * h * h,
                acc + j * h,
            )
        self._breaks = breaks
        self._durations = np.asarray(durations, dtype=float)
        self._coefs = coefs

    def derivative(self, s: Any, order: int = 0) -> FloatArray:
        """Piecewise-polynomial evaluation (segment found by binary search)."""
        s, order = _as_s(s), _check_order(order)
        idx = np.clip(np.searchsorted(self._breaks, s, side="right") - 1, 0, len(self._coefs) - 1)
        # the local time never leaves its segment: the breaks are rounded to ~1e-16 near s = 1
        # (and the last one forced to 1), so a segment much shorter than that (an S-curve's
        # jerk phases in a 1e17 s move) would otherwise be evaluated far past its end
        u = np.clip(s - self._breaks[idx], 0.0, self._durations[idx])
        c = self._coefs[idx]
        if order == 0:
            return c[..., 0] + u * (c[..., 1] + u * (c[..., 2] + u * c[..., 3]))
        if order == 1:
            return c[..., 1] + u * (2.0 * c[..., 2] + 3.0 * u * c[..., 3])
        if order == 2:
            return 2.0 * c[..., 2] + 6.0 * u * c[..., 3]
        return 6.0 * c[..., 3]

    @property
    def breaks(self) -> FloatArray:
        """Segment boundaries in normalized time (some segments may have zero length)."""
        return self._breaks.copy()


class TrapezoidalProfile(_PiecewiseProfile):
    """Trapezoidal velocity: accelerate, cruise, decelerate.

    With acceleration fraction ``f = T_a / T`` in ``(0, 1/2]`` the normalized acceleration is
    ``A = 1 / (f (1 - f))`` on ``[0, f]``, zero on ``[f, 1-f]`` and ``-A`` on ``[1-f, 1]``; the
    peak velocity is ``1 / (1 - f)``. ``f = 1/2`` is the triangular (bang-bang) profile.

    Args:
        accel_fraction: ``T_a / T`` in ``(0, 1/2]`` [-].
    """

    name = "trapezoidal"

    def __init__(self, accel_fraction: float = 0.25) -> None:
        f = as_scalar(accel_fraction, "accel_fraction")
        if not (0.0 < f <= 0.5):
            raise InvalidInputError(f"accel_fraction must be in (0, 0.5], got {accel_fraction!r}")
        self.accel_fraction = f
        self._amax = 1.0 / (f * (1.0 - f))
        if not math.isfinite(self._amax):  # f = 2e-313 (subnormal): MP'' = inf, MP = NaN
            raise InvalidInputError(
                f"accel_fraction {accel_fraction!r} is too small: the peak acceleration "
                "1 / (f (1 - f)) is not a float64; use accel_fraction >= 1e-300"
            )
        a = self._amax
        super().__init__([f, max(1.0 - 2.0 * f, 0.0), f], [0.0, 0.0, 0.0], [a, 0.0, -a])

    @property
    def peaks(self) -> tuple[float, float, float]:
        """``(1/(1-f), 1/(f(1-f)), inf)``."""
        return (1.0 / (1.0 - self.accel_fraction), self._amax, math.inf)

    @staticmethod
    def for_limits(
        distance: float, max_velocity: float, max_acceleration: float
    ) -> tuple[TrapezoidalProfile, float]:
        """Time-optimal trapezoid for ``|distance|`` under ``v_max``, ``a_max``.

        ``T_a = v/a, T = d/v + v/a`` if ``d >= v^2/a``; otherwise triangular
        ``T_a = sqrt(d/a), T = 2 T_a`` (maximum velocity not reached).

        Returns:
            The normalized profile and the duration [s] (a ramp-free profile with ``T = 0``
            for a zero distance).
        """
        d = abs(as_scalar(distance, "distance"))
        v = check_positive(max_velocity, "max_velocity")
        a = check_positive(max_acceleration, "max_acceleration")
        if d == 0.0:
            return TrapezoidalProfile(0.5), 0.0
        if d / v >= v / a:  # d >= v^2 / a, as times so that nothing overflows
            ta, total = v / a, d / v + v / a
        else:
            ta = math.sqrt(d) / math.sqrt(a)
            total = 2.0 * ta
        if not (math.isfinite(total) and total > 0.0 and ta > 0.0):
            raise InvalidInputError(
                f"a trapezoid over the distance {d!r} with max_velocity={v!r}, "
                f"max_acceleration={a!r} has a duration ({total!r} s) that is not "
                "representable in float64; rescale the units of the motion"
            )
        return TrapezoidalProfile(min(ta / total, 0.5)), total


class SCurveProfile(_PiecewiseProfile):
    """Jerk-limited 7-segment S-curve with jerks ``(+J, 0, -J, 0, -J, 0, +J)``.

    Normalized times: jerk phase ``t_j``, acceleration phase ``t_a`` (``2 t_j <= t_a``),
    cruise ``t_v = 1 - 2 t_a``. Peak acceleration ``A = J t_j``, peak velocity
    ``V = A (t_a - t_j)`` and ``MP(1) = V (t_a + t_v) = 1`` give
    ``J = 1 / (t_j (t_a - t_j) (1 - t_a))``.

    Args:
        jerk_fraction: ``t_j`` in ``(0, 1/4]`` [-].
        accel_fraction: ``t_a`` in ``[2 t_j, 1/2]`` [-].
    """

    name = "scurve"

    def __init__(self, jerk_fraction: float = 0.125, accel_fraction: float = 0.25) -> None:
        tj = as_scalar(jerk_fraction, "jerk_fraction")
        ta = as_scalar(accel_fraction, "accel_fraction")
        if not (0.0 < tj and 2.0 * tj <= ta * (1.0 + 1e-12) and ta <= 0.5 * (1.0 + 1e-12)):
            raise InvalidInputError(
                "S-curve fractions must satisfy 0 < jerk_fraction, 2 jerk_fraction <= "
                f"accel_fraction <= 0.5; got jerk_fraction={jerk_fraction!r}, "
                f"accel_fraction={accel_fraction!r}"
            )
        ta = min(ta, 0.5)
        tj = min(tj, 0.5 * ta)
        self.jerk_fraction, self.accel_fraction = tj, ta
        den = tj * (ta - tj) * (1.0 - ta)
        j = 1.0 / den if den > 0.0 else math.inf
        if not math.isfinite(j):  # subnormal fractions: an inf jerk gives NaN positions
            raise InvalidInputError(
                f"S-curve fractions jerk_fraction={jerk_fraction!r}, "
                f"accel_fraction={accel_fraction!r} are too small: the peak jerk "
                "1 / (t_j (t_a - t_j) (1 - t_a)) is not a float64; use fractions >= 1e-100"
            )
        self._peaks = (j * tj * (ta - tj), j * tj, j)
        tc = max(ta - 2.0 * tj, 0.0)
        tv = max(1.0 - 2.0 * ta, 0.0)
        super().__init__(
            [tj, tc, tj, tv, tj, tc, tj],
            [j, 0.0, -j, 0.0, -j, 0.0, j],
        )

    @property
    def peaks(self) -> tuple[float, float, float]:
        """``(V, A, J)`` as in the class docstring."""
        return self._peaks

    @staticmethod
    def for_limits(
        distance: float, max_velocity: float, max_acceleration: float, max_jerk: float
    ) -> tuple[SCurveProfile, float]:
        """Time-optimal rest-to-rest S-curve for ``|distance| = d`` under ``v, a, j`` limits.

        Acceleration phase (``T_j`` jerk time, ``T_a`` total): if ``v j >= a^2`` the maximum
        acceleration is reached, ``T_j = a/j, T_a = T_j + v/a``; else ``T_j = sqrt(v/j)``,
        ``T_a = 2 T_j``. If ``d >= v T_a`` the cruise lasts ``T_v = d/v - T_a``. Otherwise the
        maximum velocity is not reached: if ``d >= 2 a^3/j^2``, ``T_j = a/j`` and the peak
        velocity solves ``v_p^2/a + v_p a/j = d``; else ``T_j = (d / (2 j))^(1/3)``,
        ``T_a = 2 T_j``. The duration is ``T = 2 T_a + T_v``.

        Returns:
            The normalized profile and the duration [s].
        """
        d = abs(as_scalar(distance, "distance"))
        v = check_positive(max_velocity, "max_velocity")
        a = check_positive(max_acceleration, "max_acceleration")
        j = check_positive(max_jerk, "max_jerk")
        if d == 0.0:
            return SCurveProfile(0.125, 0.25), 0.0
        # Written with the times a/j, v/a, d/v, d/a (not the products v j, a^2, a^3/j^2, d a)
        # so that no intermediate over- or underflows when the durations are representable.
        t_aj, t_va = a / j, v / a
        if t_va >= t_aj:  # v j >= a^2
            tj, ta = t_aj, t_aj + t_va
        else:
            tj = math.sqrt(v) / math.sqrt(j)
            ta = 2.0 * tj
        if d / v >= ta:
            tv = d / v - ta
        else:
            tv = 0.0
            t_da = d / a
            if t_da >= 2.0 * t_aj * t_aj:  # d >= 2 a^3 / j^2
                # v_p / a = (-t_aj + sqrt(t_aj^2 + 4 d/a)) / 2, in the cancellation-free form
                tj = t_aj
                ta = tj + 2.0 * t_da / (t_aj + math.sqrt(t_aj * t_aj + 4.0 * t_da))
            else:
                tj = float(np.cbrt(0.5 * d) / np.cbrt(j))
                ta = 2.0 * tj
        total = 2.0 * ta + tv
        if not (math.isfinite(total) and total > 0.0 and tj > 0.0):
            raise InvalidInputError(
                f"an S-curve over the distance {d!r} with max_velocity={v!r}, "
                f"max_acceleration={a!r}, max_jerk={j!r} has a duration ({total!r} s) that is "
                "not representable in float64; rescale the units of the motion"
            )
        return SCurveProfile(tj / total, ta / total), total


_FIXED: dict[str, type[MotionProfile]] = {
    "ramp": RampProfile,
    "sine": SineProfile,
    "minimum_jerk": MinimumJerkProfile,
}


def _check_limit(value: float | None, name: str, required: bool, profile: str) -> float | None:
    if value is None:
        if required:
            raise InvalidInputError(f"profile '{profile}' needs {name}")
        return None
    return check_positive(value, name)


def profile_for_limits(
    profile: str,
    distance: float,
    max_velocity: float,
    max_acceleration: float | None = None,
    max_jerk: float | None = None,
) -> tuple[MotionProfile, float]:
    """Normalized profile and shortest duration [s] that keeps ``|distance|`` within limits.

    Args:
        profile: one of ``ramp, sine, trapezoidal, minimum_jerk, scurve``.
        distance: ``xT - x0`` [unit].
        max_velocity: ``v_max > 0`` [unit/s].
        max_acceleration: ``a_max > 0`` [unit/s^2]; required by ``trapezoidal`` and ``scurve``.
        max_jerk: ``j_max > 0`` [unit/s^3]; required by ``scurve``.

    Returns:
        ``(MP, T)``. Limits a shape cannot honor (ramp: acceleration and jerk; trapezoidal:
        jerk) are ignored.

    Raises:
        UnknownNameError: unknown profile name.
        InvalidInputError: a limit is missing, non-positive or not finite.
    """
    if profile not in PROFILE_NAMES:
        raise UnknownNameError("motion profile", profile, PROFILE_NAMES)
    d = as_scalar(distance, "distance")
    v = check_positive(max_velocity, "max_velocity")
    needs_a = profile in ("trapezoidal", "scurve")
    a = _check_limit(max_acceleration, "max_acceleration", needs_a, profile)
    j = _check_limit(max_jerk, "max_jerk", profile == "scurve", profile)
    shape: MotionProfile
    if profile == "trapezoidal" and a is not None:
        shape, duration = TrapezoidalProfile.for_limits(d, v, a)
    elif profile == "scurve" and a is not None and j is not None:
        shape, duration = SCurveProfile.for_limits(d, v, a, j)
    else:
        shape = _FIXED[profile]()
        duration = shape.min_duration(d, v, a, j)
    _check_representable(shape, d, duration, (v, a, j))
    return shape, duration


def _check_representable(
    shape: MotionProfile, distance: float, duration: float, limits: tuple[float | None, ...]
) -> None:
    """Refuse a motion whose duration or peak rates are not float64 numbers.

    The documented range of :func:`profile_for_limits`: the duration is finite and positive
    for a nonzero distance, and the peak velocity, acceleration and jerk of the shape (those
    that are not impulsive) are finite and within their limits up to rounding. Outside it (for
    example ``distance=1e300`` with ``max_velocity=1e308``: a peak acceleration of ~1e315) an
    :class:`InvalidInputError` is raised instead of an ``inf`` or a wrong value.
    """
    d = abs(distance)
    if d == 0.0:
        return
    names = ("velocity", "acceleration", "jerk")
    if not (math.isfinite(duration) and duration > 0.0):
        raise InvalidInputError(
            f"a '{shape.name}' motion over the distance {d!r} with max_velocity, "
            f"max_acceleration, max_jerk = {limits!r} lasts {duration!r} s, which is not "
            "representable in float64; rescale the units of the motion"
        )
    rate = d
    for k, (peak, limit) in enumerate(zip(shape.peaks, limits, strict=True)):
        rate = rate / duration  # |d| / T^(k+1), divided step by step: no T^k overflow
        if not math.isfinite(peak):
            continue  # impulsive derivative: this shape cannot honor that limit
        value = rate * peak
        if not math.isfinite(value) or (limit is not None and value > limit * (1.0 + 1e-9)):
            raise InvalidInputError(
                f"a '{shape.name}' motion over the distance {d!r} with max_velocity, "
                f"max_acceleration, max_jerk = {limits!r} has a peak {names[k]} of {value!r}, "
                "which is not representable in float64 (or rounds past its limit); rescale "
                "the units of the motion"
            )


@dataclass(frozen=True)
class MotionSample:
    """A motion sampled at given times.

    Attributes:
        time: sample times, shape ``(m,)`` [s].
        position: ``x(t)``, shape ``(m,)`` or ``(m, n)`` [unit].
        velocity: ``x'(t)`` [unit/s].
        acceleration: ``x''(t)`` [unit/s^2].
        jerk: ``x'''(t)`` [unit/s^3] (zero inside segments for piecewise profiles).
    """

    time: FloatArray
    position: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    jerk: FloatArray


def _scaled(
    profile: MotionProfile,
    t: FloatArray,
    duration: float,
    start: FloatArray | float,
    goal: FloatArray | float,
) -> list[FloatArray]:
    """``x0 + MP(t/T) d`` and ``d MP^(k)(t/T) / T^k`` for k = 1..3, at rest outside ``[0, T]``.

    ``start``/``goal`` are scalars or ``(n,)`` arrays (then the outputs are ``(m, n)``). The
    position is ``x0 + MP d`` on the first half of the profile and ``xT - (1 - MP) d`` on the
    second, so both ends are exact even when ``|x0| >> |d|``; the rates are ``MP^(k) ((d/T)/T)..``
    divided step by step so that ``T^k`` never overflows.
    """
    x0 = np.asarray(start, dtype=float)
    x1 = np.asarray(goal, dtype=float)
    d = x1 - x0
    col = (slice(None),) + (None,) * d.ndim  # profile values as a column against d
    if duration <= 0.0:
        zero = np.zeros(t.shape + d.shape)
        return [zero + x1, zero, zero.copy(), zero.copy()]
    s = t / duration
    inside = ((s >= 0.0) & (s <= 1.0))[col]
    # MP(0) = 0 and MP(1) = 1 exactly (a piecewise profile may sum to 1 - 2e-16 at s = 1)
    p = np.where(s >= 1.0, 1.0, np.where(s <= 0.0, 0.0, profile.derivative(s, 0)))[col]
    out = [np.where(p <= 0.5, x0 + d * p, x1 - d * (1.0 - p))]
    rate = d
    with np.errstate(over="ignore", under="ignore"):
        for k in range(1, 4):
            rate = rate / duration
            out.append(np.where(inside, profile.derivative(s, k)[col] * rate, 0.0))
    return out


@dataclass(frozen=True)
class PointToPointMotion:
    """Scalar motion ``x(t) = x0 + MP(t/T) (xT - x0)`` (slide 2:33).

    Attributes:
        start: ``x0`` [unit].
        goal: ``xT`` [unit].
        duration: ``T`` [s].
        profile: the normalized profile ``MP``.
    """

    start: float
    goal: float
    duration: float
    profile: MotionProfile

    def evaluate(self, t: Any) -> MotionSample:
        """Sample position, velocity, acceleration, jerk at times ``t`` [s].

        Times outside ``[0, T]`` hold the start or goal at rest.
        """
        t = np.atleast_1d(as_float_array(t, "t"))
        check_finite(t, "t")
        if t.ndim != 1:
            raise ShapeError("t", (-1,), t.shape)
        p, v, a, j = _scaled(self.profile, t, self.duration, self.start, self.goal)
        return MotionSample(t, p, v, a, j)


def plan_motion(
    start: float,
    goal: float,
    max_velocity: float,
    max_acceleration: float | None = None,
    max_jerk: float | None = None,
    profile: str = "scurve",
) -> PointToPointMotion:
    """Shortest scalar motion from ``start`` to ``goal`` with the given profile and limits.

    See :func:`profile_for_limits` for the arguments and errors.
    """
    x0, x1 = as_vector([start, goal], 2, "start/goal")
    distance = _distance(x0, x1, "goal - start")
    shape, duration = profile_for_limits(
        profile, distance, max_velocity, max_acceleration, max_jerk
    )
    return PointToPointMotion(float(x0), float(x1), duration, shape)


def _distance(start: Any, goal: Any, name: str) -> Any:
    """``goal - start`` if finite; else the subtraction overflowed (refused, no RuntimeWarning).

    ``start`` and ``goal`` are finite (checked by the caller), so a non-finite difference is
    an overflow: the distance to travel is beyond float64, never a value to return.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        d = goal - start
        finite_d = np.isfinite(d)
    if not np.all(finite_d):
        raise InvalidInputError(
            f"{name} overflows float64 ({d!r}); the distance to travel must be below "
            "1.8e308: rescale the units of the motion"
        )
    return d


class SyncMode(str, Enum):
    """How joints are synchronized.

    STRAIGHT_LINE: one shared profile, ``q(t) = q0 + MP(t/T) (qT - q0)`` (slide 2:34), so the
        motion is a straight line in joint space; the profile is time-optimal for the
        normalized limits ``v_s = min_i v_i / |d_i|`` (same for ``a``, ``j``).
    TIME_SCALED: every joint keeps its own time-optimal profile ``MP_i`` (duration ``T_i``),
        stretched to the slowest duration ``T = max_i T_i``: ``q_i(t) = q0_i + MP_i(t/T) d_i``.
        Velocities scale by ``T_i/T <= 1``, accelerations by ``(T_i/T)^2``, jerks by
        ``(T_i/T)^3``, so every limit still holds.
    """

    STRAIGHT_LINE = "straight_line"
    TIME_SCALED = "time_scaled"


@dataclass(frozen=True)
class SynchronizedMotion:
    """Multi-joint motion in which all joints start and arrive together.

    Attributes:
        start: ``q0``, shape ``(n,)``.
        goal: ``qT``, shape ``(n,)``.
        duration: common duration ``T`` [s].
        profiles: one normalized profile per joint (the same object for all joints in
            straight-line mode).
        joint_durations: each joint's own shortest duration ``T_i`` [s].
        limiting_joint: index of the joint that sets ``T`` (``-1`` if nothing moves).
        mode: the synchronization mode.
    """

    start: FloatArray
    goal: FloatArray
    duration: float
    profiles: tuple[MotionProfile, ...]
    joint_durations: FloatArray
    limiting_joint: int
    mode: SyncMode

    def evaluate(self, t: Any) -> MotionSample:
        """Sample the joint motion at times ``t`` [s]; arrays have shape ``(m, n)``."""
        t = np.atleast_1d(as_float_array(t, "t"))
        check_finite(t, "t")
        if t.ndim != 1:
            raise ShapeError("t", (-1,), t.shape)
        n = self.start.shape[0]
        out = np.empty((4, t.shape[0], n))
        if self.mode is SyncMode.STRAIGHT_LINE:
            vals = _scaled(self.profiles[0], t, self.duration, self.start, self.goal)
            for k in range(4):
                out[k] = vals[k]
        else:
            for i, prof in enumerate(self.profiles):
                vals = _scaled(prof, t, self.duration, self.start[i], self.goal[i])
                for k in range(4):
                    out[k, :, i] = vals[k]
        return MotionSample(t, out[0], out[1], out[2], out[3])


def _limit_vector(x: Any, n: int, name: str) -> FloatArray | None:
    if x is None:
        return None
    arr = as_float_array(x, name)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    vec = as_vector(arr, n, name)
    if np.any(vec <= 0.0):
        bad = np.flatnonzero(vec <= 0.0).tolist()
        raise InvalidInputError(f"{name} must be > 0 for every joint; non-positive at {bad}")
    return vec


def synchronize(
    start: Any,
    goal: Any,
    max_velocity: Any,
    max_acceleration: Any = None,
    max_jerk: Any = None,
    profile: str = "scurve",
    mode: SyncMode | str = SyncMode.STRAIGHT_LINE,
) -> SynchronizedMotion:
    """Synchronized multi-joint point-to-point motion (slide 2:34).

    Args:
        start: ``q0``, shape ``(n,)`` [rad or m].
        goal: ``qT``, shape ``(n,)``.
        max_velocity: per-joint ``v_max`` (scalar or ``(n,)``) [unit/s].
        max_acceleration: per-joint ``a_max`` [unit/s^2] or ``None``.
        max_jerk: per-joint ``j_max`` [unit/s^3] or ``None``.
        profile: profile name, see :func:`profile_for_limits`.
        mode: ``"straight_line"`` or ``"time_scaled"`` (see :class:`SyncMode`).

    Returns:
        The synchronized motion; the slowest joint sets the duration.

    Raises:
        ShapeError: mismatched shapes.
        NotFiniteError: NaN/inf in the inputs.
        InvalidInputError: non-positive limits.
        UnknownNameError: unknown profile or mode.
    """
    q0 = as_vector(start, None, "start")
    n = q0.shape[0]
    try:
        q1 = as_vector(goal, n, "goal")
    except ShapeError as exc:
        raise ShapeError("goal", (n,), exc.actual) from None
    try:
        mode = SyncMode(mode)
    except ValueError:
        raise UnknownNameError("sync mode", str(mode), [m.value for m in SyncMode]) from None
    if profile not in PROFILE_NAMES:
        raise UnknownNameError("motion profile", profile, PROFILE_NAMES)
    v = _limit_vector(max_velocity, n, "max_velocity")
    if v is None:
        raise InvalidInputError("max_velocity is required")
    a = _limit_vector(max_acceleration, n, "max_acceleration")
    j = _limit_vector(max_jerk, n, "max_jerk")
    d = _distance(q0, q1, "goal - start")
    dist = np.abs(d)
    moving = dist > 0.0

    def pick(arr: FloatArray | None, i: int) -> float | None:
        return None if arr is None else float(arr[i])

    joint_durations = np.zeros(n)
    shapes: list[MotionProfile] = []
    for i in range(n):
        shape_i, t_i = profile_for_limits(profile, dist[i], v[i], pick(a, i), pick(j, i))
        shapes.append(shape_i)
        joint_durations[i] = t_i
    limiting = int(np.argmax(joint_durations)) if np.any(moving) else -1
    if mode is SyncMode.TIME_SCALED:
        duration = float(joint_durations.max()) if n else 0.0
        return SynchronizedMotion(q0, q1, duration, tuple(shapes), joint_durations, limiting, mode)
    if not np.any(moving):
        shape, duration = profile_for_limits(profile, 0.0, 1.0, 1.0, 1.0)
        return SynchronizedMotion(q0, q1, 0.0, (shape,), joint_durations, -1, mode)

    def scaled_limit(arr: FloatArray | None) -> float | None:
        return None if arr is None else float(np.min(arr[moving] / dist[moving]))

    vs = float(np.min(v[moving] / dist[moving]))
    shape, duration = profile_for_limits(profile, 1.0, vs, scaled_limit(a), scaled_limit(j))
    # the joint whose own optimum is closest to the common duration limits the motion
    limiting = int(np.argmax(np.where(moving, joint_durations, -np.inf)))
    return SynchronizedMotion(q0, q1, duration, (shape,), joint_durations, limiting, mode)
