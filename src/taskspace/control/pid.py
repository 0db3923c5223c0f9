"""Discrete P, PD and PID controllers (slides 5:6-5:17) with anti-windup.

``u = Kp (q* - q) + Kd (q'* - q') + Ki int_0^t (q* - q(s)) ds``

The gains are set directly or from the wavelength ``lambda`` and damping ratio ``xi`` of the
closed loop of a point mass of mass ``m`` (slide 5:14): ``Kp = m / lambda^2``,
``Kd = 2 m xi / lambda``. The controller works on vectors (one independent loop per entry) and
is the ``controller(t, q, v)`` of :func:`taskspace.dynamics.simulate` for robots whose joints
are vector-valued (``nq == nv``).

Thread safety: :class:`PIDGains` and :class:`PIDOptions` are immutable; a :class:`PIDController` is
stateful (integral, time of the previous call, saturation) and not locked: one controller per
thread (two threads calling one controller would mix their integrals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, as_vector, check_positive
from taskspace.errors import InvalidInputError


@dataclass(frozen=True)
class PIDGains:
    """Gains of a PID loop.

    Attributes:
        kp: proportional gain [N/m or N m/rad].
        kd: derivative gain [N s/m or N m s/rad].
        ki: integral gain [N/(m s) or N m/(rad s)].
    """

    kp: float
    kd: float = 0.0
    ki: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.kp, "kp", strict=False)
        check_positive(self.kd, "kd", strict=False)
        check_positive(self.ki, "ki", strict=False)

    @staticmethod
    def from_wavelength(
        mass: float, wavelength: float, damping_ratio: float, ki: float = 0.0
    ) -> PIDGains:
        """``Kp = m / lambda^2``, ``Kd = 2 m xi / lambda`` (slide 5:14).

        Args:
            mass: ``m`` [kg] (> 0).
            wavelength: ``lambda = 1 / omega_0`` [s] (> 0).
            damping_ratio: ``xi`` (>= 0): > 1 overdamped, 1 critical, < 1 oscillatory.
            ki: integral gain.
        """
        m = check_positive(mass, "mass [kg]")
        lam = check_positive(wavelength, "wavelength [s]")
        xi = check_positive(damping_ratio, "damping_ratio", strict=False)
        kp, kd = m / lam / lam, 2.0 * m * xi / lam  # lam**2 underflowed: ZeroDivisionError
        if not (math.isfinite(kp) and math.isfinite(kd) and kp > 0.0):
            raise InvalidInputError(
                f"mass {m!r} kg and wavelength {lam!r} s give gains kp = {kp:g}, kd = {kd:g} "
                "outside the floats; rescale the mass or the wavelength"
            )
        return PIDGains(kp=kp, kd=kd, ki=ki)

    def wavelength(self, mass: float) -> float:
        """``lambda = sqrt(m / Kp)`` [s] of a point mass ``m`` under these gains."""
        m = check_positive(mass, "mass [kg]")
        return math.sqrt(m / self.kp) if self.kp > 0 else math.inf

    def damping_ratio(self, mass: float) -> float:
        """``xi = Kd / sqrt(4 m Kp)`` for a point mass ``m``."""
        m = check_positive(mass, "mass [kg]")
        return self.kd / math.sqrt(4.0 * m * self.kp) if self.kp > 0 else math.inf


@dataclass(frozen=True, kw_only=True)
class PIDOptions:
    """Settings of :class:`PIDController`.

    Attributes:
        output_limit: saturation ``|u| <= output_limit`` per entry [N or N m]; ``None``: none.
        anti_windup: while the output saturates, stop integrating errors that push further
            into saturation (conditional integration); without it the integral winds up.
        integral_limit: clamp of the integral state ``|int e dt|`` [m s]; ``None``: none.
    """

    output_limit: float | None = None
    anti_windup: bool = True
    integral_limit: float | None = None


class PIDController:
    """Discrete PID ``u = Kp e + Kd (q'* - q') + Ki I``, ``e = q* - q``, ``I += e dt_k``.

    Called as ``u = pid(t, q, v)``; ``dt_k`` is the time since the previous call (the integral
    uses the rectangle rule with the current error). The derivative acts on the measured
    velocity ``v`` (no derivative kick when the target jumps).

    Args:
        gains: :class:`PIDGains` (or ``P``/``PD`` by leaving ``ki``/``kd`` at zero).
        target: ``q*`` (scalar or vector).
        target_velocity: ``q'*`` (default zero).
        options: saturation and anti-windup.
    """

    def __init__(
        self,
        gains: PIDGains,
        target: Any,
        target_velocity: Any = None,
        options: PIDOptions | None = None,
    ) -> None:
        if not isinstance(gains, PIDGains):
            raise InvalidInputError(f"gains must be a PIDGains, got {type(gains).__name__}")
        self.gains = gains
        if options is not None and not isinstance(options, PIDOptions):
            raise InvalidInputError(f"options must be a PIDOptions, got {type(options).__name__}")
        self.options = options or PIDOptions()
        if self.options.output_limit is not None:
            check_positive(self.options.output_limit, "output_limit")
        if self.options.integral_limit is not None:
            check_positive(self.options.integral_limit, "integral_limit")
        self.target = as_vector(np.atleast_1d(as_float_array(target, "target")), None, "target")
        n = self.target.size
        self.target_velocity = (
            np.zeros(n)
            if target_velocity is None
            else as_vector(
                np.atleast_1d(as_float_array(target_velocity, "target_velocity")),
                n,
                "target_velocity",
            )
        )
        self.integral = np.zeros(n)
        self._t_prev: float | None = None
        self.saturated = np.zeros(n, dtype=bool)

    @staticmethod
    def p(kp: float, target: Any) -> PIDController:
        """Proportional control ``u = Kp (q* - q)`` (slide 5:7)."""
        return PIDController(PIDGains(kp=kp), target)

    @staticmethod
    def pd(kp: float, kd: float, target: Any, target_velocity: Any = None) -> PIDController:
        """PD control ``u = Kp (q* - q) + Kd (q'* - q')`` (slide 5:10)."""
        return PIDController(PIDGains(kp=kp, kd=kd), target, target_velocity)

    def _output(self, q: FloatArray, v: FloatArray, e: FloatArray, dv: FloatArray) -> FloatArray:
        """``kp e + kd dv + ki integral`` per joint; ``+-inf`` where the exact sum is beyond floats.

        The float sum overflowed at an intermediate term: kp e = 2e308 (inf) plus
        kd dv = -1.7e308 and ki I = -1.7e308 gave +inf, clipped to +output_limit, where the
        exact -1.4e308 saturates at -output_limit. Such joints are recomputed exactly
        (rational arithmetic on the float inputs: e and dv from the target and the measured
        q, v, which are finite) and rounded once.
        """
        g = self.gains
        with np.errstate(over="ignore", invalid="ignore"):
            terms = (g.kp * e, g.kd * dv, g.ki * self.integral)
            u = terms[0] + terms[1] + terms[2]
            ok = np.isfinite(u) & np.isfinite(terms[0]) & np.isfinite(terms[1])
            ok &= np.isfinite(terms[2])
        if ok.all():
            return u
        kp, kd, ki = Fraction(g.kp), Fraction(g.kd), Fraction(g.ki)
        for i in np.flatnonzero(~ok):
            exact = (
                kp * (Fraction(float(self.target[i])) - Fraction(float(q[i])))
                + kd * (Fraction(float(self.target_velocity[i])) - Fraction(float(v[i])))
                + ki * Fraction(float(self.integral[i]))
            )
            try:
                u[i] = float(exact)
            except OverflowError:
                u[i] = math.inf if exact > 0 else -math.inf
        return u

    def reset(self) -> None:
        """Clear the integral and the time of the previous call."""
        self.integral[:] = 0.0
        self._t_prev = None
        self.saturated[:] = False

    def __call__(self, t: float, q: Any, v: Any) -> FloatArray:
        """Control ``u`` at time ``t`` [s] for position ``q`` and velocity ``v``.

        Raises:
            InvalidInputError: time went backwards (the controller is stateful), or the
                exact output (without ``output_limit``) or the integral (without
                ``integral_limit``) is beyond float64 (the controller's state is then left
                unchanged). A float sum that overflows at an intermediate term is recomputed
                exactly, so a saturated output has the sign of the exact sum.
            ShapeError, NotFiniteError: bad ``q``/``v``.
        """
        n = self.target.size
        qa = as_vector(np.atleast_1d(as_float_array(q, "q")), n, "q")
        va = as_vector(np.atleast_1d(as_float_array(v, "v")), n, "v")
        t = as_scalar(t, "t [s]")
        dt = 0.0 if self._t_prev is None else t - self._t_prev
        if dt < -1e-9 * max(1.0, abs(t)):
            raise InvalidInputError(
                f"PID time went backwards (t={t:g} after {self._t_prev:g}); call reset() "
                "before restarting"
            )
        dt = max(dt, 0.0)
        t_prev, saturated = self._t_prev, self.saturated
        self._t_prev = t if self._t_prev is None else max(t, self._t_prev)
        g, opts = self.gains, self.options
        with np.errstate(over="ignore", invalid="ignore"):
            e = self.target - qa  # (finite or overflowed: _output is exact either way)
            dv = self.target_velocity - va
            # e dt from halves: e overflowed (|q* - q| > 1.8e308) although e dt may not
            step = (0.5 * self.target - 0.5 * qa) * dt * 2.0
        previous = self.integral.copy()
        if g.ki != 0.0 and dt > 0.0:
            with np.errstate(over="ignore", invalid="ignore"):
                self.integral += step
            if opts.integral_limit is not None:
                np.clip(self.integral, -opts.integral_limit, opts.integral_limit, self.integral)
            if not np.all(np.isfinite(self.integral)):
                # an integral beyond float64 cannot be stored (ki times it is unknown)
                self.integral[:] = previous
                self._t_prev = t_prev
                with np.errstate(over="ignore", invalid="ignore"):
                    bad = np.flatnonzero(~np.isfinite(previous + step)).tolist()
                raise InvalidInputError(
                    f"the PID integral overflows float64 at joints {bad} (error "
                    f"{e.tolist()!r}, dt={dt!r}): rescale the units or set "
                    "options.integral_limit"
                )
        u = self._output(qa, va, e, dv)
        if opts.output_limit is not None:
            limit = opts.output_limit
            self.saturated = np.abs(u) > limit
            if opts.anti_windup and g.ki != 0.0 and np.any(self.saturated):
                # conditional integration: keep the old integral where the error pushes the
                # output further into saturation
                winding = self.saturated & (np.sign(e) == np.sign(u))
                self.integral[winding] = previous[winding]
                u = self._output(qa, va, e, dv)
            u = np.clip(u, -limit, limit)
        if not np.all(np.isfinite(u)):
            # gains times errors beyond float64 (e.g. kd = 1e308, v = 1e308): refuse instead
            # of returning inf or NaN, and leave the controller's state as it was
            self.integral[:] = previous
            self._t_prev, self.saturated = t_prev, saturated
            bad = np.flatnonzero(~np.isfinite(u)).tolist()
            raise InvalidInputError(
                f"the PID output overflows float64 at joints {bad} (kp={g.kp!r}, kd={g.kd!r}, "
                f"ki={g.ki!r}, error {e.tolist()!r}): rescale the gains or the units, or set "
                "options.output_limit (a saturated output stays finite)"
            )
        return u
