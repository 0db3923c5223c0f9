"""The 1-D point mass under PD control and its closed-form responses (slides 5:5-5:14).

``m q'' = u = Kp (q* - q) + Kd (0 - q')``. With the error ``e = q - q*`` this is
``m e'' + Kd e' + Kp e = 0``; trying ``e = b exp(w t)`` gives ``m w^2 + Kd w + Kp = 0``,
``w = (-Kd +- sqrt(Kd^2 - 4 m Kp)) / 2m`` (slide 5:11):

* ``Kd^2 > 4 m Kp``: two real roots, overdamped (slide 5:12);
* ``Kd^2 = 4 m Kp``: a double root ``-Kd / 2m``, critically damped;
* ``Kd^2 < 4 m Kp``: oscillation with frequency ``sqrt(Kp/m - Kd^2/4m^2)`` decaying as
  ``exp(-Kd t / 2m)`` (``Kd = 0``: the undamped oscillation of slide 5:8).

The closed forms below satisfy the initial conditions ``e(0) = q0 - q*``, ``e'(0) = v0``.

Thread safety: the functions keep their state local to the call; :class:`DampingRegime` is
immutable; a :class:`PointMassResponse` is plain result data (arrays), not locked: do not modify it
while another thread reads it.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_positive
from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.model.robot import Robot

CRITICAL_TOLERANCE = 1e-9
"""Relative tolerance on ``Kd^2 - 4 m Kp`` under which the damping counts as critical."""


class DampingRegime(enum.Enum):
    """Behavior of ``m e'' + Kd e' + Kp e = 0`` (slide 5:14)."""

    UNDAMPED = "undamped"
    """``Kd = 0``: oscillation with constant amplitude (P control, slide 5:8)."""
    UNDERDAMPED = "underdamped"
    """``xi < 1``: decaying oscillation."""
    CRITICALLY_DAMPED = "critically_damped"
    """``xi = 1``: fastest decay without oscillation."""
    OVERDAMPED = "overdamped"
    """``xi > 1``: slow exponential decay."""


@dataclass
class PointMassResponse:
    """Closed-form trajectory of the PD-controlled point mass.

    Attributes:
        t: times (N,) [s].
        q: positions (N,) [m].
        v: velocities (N,) [m/s].
        regime: the damping regime.
        damping_ratio: ``xi = Kd / sqrt(4 m Kp)`` (slide 5:14).
        wavelength: ``lambda = sqrt(m / Kp)`` [s] (inf for ``Kp = 0``).
        exponents: the roots ``w`` of ``m w^2 + Kd w + Kp = 0`` [1/s] (complex).
    """

    t: FloatArray
    q: FloatArray
    v: FloatArray
    regime: DampingRegime
    damping_ratio: float
    wavelength: float
    exponents: tuple[complex, complex]


def _check_gains(mass: float, kp: float, kd: float) -> tuple[float, float, float]:
    return (
        check_positive(mass, "mass [kg]"),
        check_positive(kp, "kp [N/m]"),
        check_positive(kd, "kd [N s/m]", strict=False),
    )


def damping_ratio(mass: float, kp: float, kd: float) -> float:
    """``xi = Kd / sqrt(4 m Kp)`` (slide 5:14)."""
    mass, kp, kd = _check_gains(mass, kp, kd)
    return kd / math.sqrt(4.0 * mass * kp)


def damping_regime(mass: float, kp: float, kd: float) -> DampingRegime:
    """Classify ``m e'' + Kd e' + Kp e = 0`` by the sign of ``Kd^2 - 4 m Kp`` (slide 5:12)."""
    mass, kp, kd = _check_gains(mass, kp, kd)
    if kd == 0.0:
        return DampingRegime.UNDAMPED
    disc = kd * kd - 4.0 * mass * kp
    if abs(disc) <= CRITICAL_TOLERANCE * 4.0 * mass * kp:
        return DampingRegime.CRITICALLY_DAMPED
    return DampingRegime.OVERDAMPED if disc > 0 else DampingRegime.UNDERDAMPED


def _times(t: Any) -> FloatArray:
    arr = np.atleast_1d(as_float_array(t, "t"))  # text / complex: bare ValueError before
    if arr.ndim != 1:
        raise InvalidInputError(
            f"t must be a scalar or a 1-D array of times, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise NotFiniteError("t", [int(i) for i in np.flatnonzero(~np.isfinite(arr))])
    return arr


def _response(
    t: Any,
    mass: float,
    kp: float,
    kd: float,
    q0: float,
    v0: float,
    target: float,
    expected: tuple[DampingRegime, ...] | None,
) -> PointMassResponse:
    mass, kp, kd = _check_gains(mass, kp, kd)
    # as_scalar: "x", None and complex values gave a bare ValueError / TypeError
    q0, v0, target = (as_scalar(v, n) for v, n in ((q0, "q0"), (v0, "v0"), (target, "target")))
    ts = _times(t)
    regime = damping_regime(mass, kp, kd)
    if expected is not None and regime not in expected:
        xi = kd / math.sqrt(4.0 * mass * kp)
        raise InvalidInputError(
            f"gains kp={kp:g}, kd={kd:g}, m={mass:g} give damping ratio xi={xi:.6g} "
            f"({regime.value}); this function needs "
            + " or ".join(r.value for r in expected)
            + "; use pd_response for any regime"
        )
    e0 = q0 - target
    sigma = kd / (2.0 * mass)  # decay rate Kd/2m [1/s]
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        e, ed, roots = _modes(ts, mass, kp, kd, e0, v0, sigma, regime)
    if not (np.isfinite(e).all() and np.isfinite(ed).all()):
        raise InvalidInputError(
            f"the response overflows for kp={kp:g}, kd={kd:g}, m={mass:g} over t up to "
            f"{float(np.max(np.abs(ts))):g} s (growing mode for t < 0, or values beyond the "
            "floats): rescale the units"
        )
    return PointMassResponse(
        t=ts,
        q=target + e,
        v=ed,
        regime=regime,
        damping_ratio=kd / math.sqrt(4.0 * mass * kp),
        wavelength=math.sqrt(mass / kp),
        exponents=roots,
    )


def _modes(
    ts: FloatArray,
    mass: float,
    kp: float,
    kd: float,
    e0: float,
    v0: float,
    sigma: float,
    regime: DampingRegime,
) -> tuple[FloatArray, FloatArray, tuple[complex, complex]]:
    """Error and its rate at ``ts`` for the regime's closed form."""
    if regime is DampingRegime.OVERDAMPED:
        # w2 = -sigma - root without cancellation, w1 from w1 w2 = kp / m: -sigma + root lost
        # its digits for kd >> sqrt(m kp) (kd = 1e8, kp = m = 1: w1 -7.45e-9 instead of
        # -1e-8) and kd^2 overflowed above 1e154 (NaN responses)
        ratio = (4.0 * mass * kp / kd) / kd
        w2 = -sigma * (1.0 + math.sqrt(1.0 - ratio))
        w1 = (kp / mass) / w2
        c1 = (v0 - w2 * e0) / (w1 - w2)
        c2 = e0 - c1
        x1, x2 = np.exp(w1 * ts), np.exp(w2 * ts)
        e = c1 * x1 + c2 * x2
        ed = c1 * w1 * x1 + c2 * w2 * x2
        roots = (complex(w1), complex(w2))
    elif regime is DampingRegime.CRITICALLY_DAMPED:
        w = -sigma
        x = np.exp(w * ts)
        c = v0 - w * e0
        e = (e0 + c * ts) * x
        ed = (c + w * (e0 + c * ts)) * x
        roots = (complex(w), complex(w))
    else:
        wd = math.sqrt(max(kp / mass - sigma * sigma, 0.0))  # damped frequency [rad/s]
        b = (v0 + sigma * e0) / wd
        cos, sin, x = np.cos(wd * ts), np.sin(wd * ts), np.exp(-sigma * ts)
        e = x * (e0 * cos + b * sin)
        ed = x * ((b * wd - sigma * e0) * cos - (e0 * wd + sigma * b) * sin)
        roots = (complex(-sigma, wd), complex(-sigma, -wd))
    return e, ed, roots


def pd_response(
    t: Any,
    *,
    mass: float,
    kp: float,
    kd: float,
    q0: float,
    v0: float = 0.0,
    target: float = 0.0,
) -> PointMassResponse:
    """Closed-form ``q(t)`` of ``m q'' = Kp (q* - q) - Kd q'`` in any regime (slides 5:8-5:14).

    Args:
        t: time(s) [s].
        mass: ``m`` [kg] (> 0).
        kp: proportional gain [N/m] (> 0).
        kd: derivative gain [N s/m] (>= 0).
        q0: initial position [m].
        v0: initial velocity [m/s].
        target: ``q*`` [m].
    """
    return _response(t, mass, kp, kd, q0, v0, target, None)


def overdamped_response(
    t: Any, *, mass: float, kp: float, kd: float, q0: float, v0: float = 0.0, target: float = 0.0
) -> PointMassResponse:
    """``e(t) = c1 exp(w1 t) + c2 exp(w2 t)``, ``w1,2 = (-Kd +- sqrt(Kd^2 - 4mKp)) / 2m``.

    Needs ``Kd^2 > 4 m Kp`` (slide 5:12); see :func:`pd_response` for the arguments.
    """
    return _response(t, mass, kp, kd, q0, v0, target, (DampingRegime.OVERDAMPED,))


def critically_damped_response(
    t: Any, *, mass: float, kp: float, kd: float, q0: float, v0: float = 0.0, target: float = 0.0
) -> PointMassResponse:
    """``e(t) = (e0 + (v0 + Kd e0 / 2m) t) exp(-Kd t / 2m)``; needs ``Kd^2 = 4 m Kp``."""
    return _response(t, mass, kp, kd, q0, v0, target, (DampingRegime.CRITICALLY_DAMPED,))


def underdamped_response(
    t: Any, *, mass: float, kp: float, kd: float, q0: float, v0: float = 0.0, target: float = 0.0
) -> PointMassResponse:
    """``e(t) = exp(-s t) (e0 cos(w t) + (v0 + s e0)/w sin(w t))``, ``s = Kd/2m``.

    ``w = sqrt(Kp/m - Kd^2/4m^2)`` (slide 5:12); needs ``Kd^2 < 4 m Kp`` (``Kd = 0`` is the
    undamped oscillation of slide 5:8).
    """
    return _response(
        t,
        mass,
        kp,
        kd,
        q0,
        v0,
        target,
        (DampingRegime.UNDERDAMPED, DampingRegime.UNDAMPED),
    )


def point_mass_pid_matrix(mass: float, kp: float, kd: float, ki: float) -> FloatArray:
    """System matrix of the PID-controlled point mass in the extended state (slide 5:15).

    State ``z = (q - q*, q', e_int)`` with ``e_int = int (q* - q) dt`` and a constant target:
    ``z' = A z``, ``A = [[0, 1, 0], [-Kp/m, -Kd/m, Ki/m], [-1, 0, 0]]``.

    Args:
        mass: ``m`` [kg].
        kp: [N/m]; kd: [N s/m]; ki: [N/(m s)].
    """
    mass = check_positive(mass, "mass [kg]")
    kp = check_positive(kp, "kp [N/m]", strict=False)
    kd = check_positive(kd, "kd [N s/m]", strict=False)
    ki = check_positive(ki, "ki [N/(m s)]", strict=False)
    return np.array([[0.0, 1.0, 0.0], [-kp / mass, -kd / mass, ki / mass], [-1.0, 0.0, 0.0]])


def point_mass_robot(mass: float = 1.0, name: str = "point_mass") -> Robot:
    """A Pinocchio robot for the 1-D point mass of slide 5:6: one prismatic joint along x.

    Gravity acts along -z, so it does not affect the motion: ``q'' = u / m``.

    Args:
        mass: ``m`` [kg].
        name: robot name.
    """
    mass = check_positive(mass, "mass [kg]")
    model = pin.Model()
    model.name = name
    jid = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(
        jid, pin.Inertia(mass, np.zeros(3), np.zeros((3, 3))), pin.SE3.Identity()
    )
    model.addBodyFrame("mass", jid, pin.SE3.Identity(), 0)
    model.lowerPositionLimit = np.array([-np.inf])
    model.upperPositionLimit = np.array([np.inf])
    empty = pin.GeometryModel()
    return Robot(model, empty, pin.GeometryModel(), name=name, end_effectors=("mass",))
