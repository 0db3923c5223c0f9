"""The Euler-Lagrange equation of a pendulum, derived on paper (slides 5:20-5:22).

Generalized coordinate ``q = theta`` (0: hanging straight down), a mass ``m`` at distance
``l`` from the hinge, with rotational inertia ``I`` about the hinge axis through the mass:

``T = 1/2 (m l^2 + I) theta'^2``, ``U = -m g l cos(theta)``, ``L = T - U``

``u = d/dt dL/dtheta' - dL/dtheta = (m l^2 + I) theta'' + m g l sin(theta)``.

The registry's ``pendulum`` robot (1 kg at 1 m, revolute about y) realizes this model; the
tests compare these closed forms with Pinocchio's Newton-Euler recursion.

Thread safety: the functions build their own Pinocchio data (or none) per call and may run from
several threads.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace._validation import check_positive
from taskspace.errors import InvalidInputError

STANDARD_GRAVITY = 9.81
"""Gravity used by Pinocchio's default model [m/s^2]."""


def _check(mass: float, length: float, inertia: float, gravity: float) -> None:
    check_positive(mass, "mass [kg]")
    check_positive(length, "length [m]")
    check_positive(inertia, "inertia [kg m^2]", strict=False)
    check_positive(gravity, "gravity [m/s^2]", strict=False)


def _array(x: Any, name: str) -> Any:
    arr = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(arr)):
        from taskspace.errors import NotFiniteError

        raise NotFiniteError(name, [int(i) for i in np.flatnonzero(~np.isfinite(arr.ravel()))])
    return arr


def _broadcast(a: Any, b: Any, names: str) -> None:
    """Refuse arrays whose shapes do not broadcast (numpy's bare ValueError before)."""
    try:
        np.broadcast_shapes(np.shape(a), np.shape(b))
    except ValueError:
        raise InvalidInputError(
            f"{names} must have broadcastable shapes, got shapes {np.shape(a)} and {np.shape(b)}"
        ) from None


def pendulum_torque(
    theta: Any,
    theta_ddot: Any,
    *,
    mass: float = 1.0,
    length: float = 1.0,
    inertia: float = 0.0,
    gravity: float = STANDARD_GRAVITY,
) -> Any:
    """Inverse dynamics ``u = (m l^2 + I) theta'' + m g l sin(theta)`` [N m] (slide 5:22).

    The velocity does not appear: a single pendulum has no Coriolis term.

    Args:
        theta: angle(s) from the downward vertical [rad] (scalar or array).
        theta_ddot: angular acceleration(s) [rad/s^2].
        mass: point mass ``m`` [kg].
        length: distance ``l`` from the hinge to the mass [m].
        inertia: rotational inertia ``I`` of the body about its center [kg m^2].
        gravity: magnitude ``g`` [m/s^2].
    """
    _check(mass, length, inertia, gravity)
    th = _array(theta, "theta")
    acc = _array(theta_ddot, "theta_ddot")
    _broadcast(th, acc, "theta and theta_ddot")
    return (mass * length**2 + inertia) * acc + mass * gravity * length * np.sin(th)


def pendulum_acceleration(
    theta: Any,
    torque: Any,
    *,
    mass: float = 1.0,
    length: float = 1.0,
    inertia: float = 0.0,
    gravity: float = STANDARD_GRAVITY,
) -> Any:
    """Forward dynamics ``theta'' = (u - m g l sin(theta)) / (m l^2 + I)`` [rad/s^2]."""
    _check(mass, length, inertia, gravity)
    th = _array(theta, "theta")
    u = _array(torque, "torque")
    _broadcast(th, u, "theta and torque")
    return (u - mass * gravity * length * np.sin(th)) / (mass * length**2 + inertia)


def pendulum_energy(
    theta: Any,
    theta_dot: Any,
    *,
    mass: float = 1.0,
    length: float = 1.0,
    inertia: float = 0.0,
    gravity: float = STANDARD_GRAVITY,
) -> Any:
    """Total energy ``T + U = 1/2 (m l^2 + I) theta'^2 - m g l cos(theta)`` [J] (slide 5:22)."""
    _check(mass, length, inertia, gravity)
    th = _array(theta, "theta")
    w = _array(theta_dot, "theta_dot")
    _broadcast(th, w, "theta and theta_dot")
    return 0.5 * (mass * length**2 + inertia) * w**2 - mass * gravity * length * np.cos(th)
