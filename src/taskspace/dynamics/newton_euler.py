"""What the Newton-Euler recursion computes besides inverse dynamics (slide 5:24).

With ``u = NE(q, q', q'')`` the recursive Newton-Euler algorithm (Pinocchio's ``pin.rnea``):

* gravity terms: ``G(q) = NE(q, 0, 0)``
* Coriolis, centrifugal and gravity terms: ``C(q, q') q' + G(q) = NE(q, q', 0)``
* the inertia matrix column by column: ``M(q) e_i = NE(q, 0, e_i) - G(q)`` (the slide omits
  ``G``: it assumes no gravity; here gravity is subtracted).

These are the lecture's constructions; Pinocchio's dedicated algorithms
(``computeGeneralizedGravity``, ``nonLinearEffects``, ``crba``) compute the same quantities
faster and are used by the tests as the reference.

Thread safety: the functions build their own Pinocchio data (or none) per call and may run from
several threads.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot


_T = TypeVar("_T")


def finite_result(value: _T, what: str, **inputs: FloatArray) -> _T:
    """``value`` if finite, else InvalidInputError naming the overflow and the input sizes.

    Finite inputs whose products overflow float64 (``v = 1e300``: ``v^2`` is inf, then
    ``inf - inf``) gave NaN answers silently.
    """
    arr = np.asarray(value)
    if np.isfinite(arr).all():
        return value
    sizes = ", ".join(
        f"|{k}|_inf = {float(np.max(np.abs(x), initial=0.0)):.3g}" for k, x in inputs.items()
    )
    raise InvalidInputError(
        f"{what} overflows float64 ({sizes}): the inputs are beyond the physical range of the "
        "robot; rescale them (or the units)"
    )


def inverse_dynamics(robot: Robot, q: Any, v: Any, a: Any) -> FloatArray:
    """``u = NE(q, v, a) = M(q) a + C(q, v) v + G(q)`` [N m, N] (slides 5:23, 5:29).

    Args:
        robot: the robot.
        q: configuration (nq).
        v: velocity (nv) [rad/s, m/s].
        a: acceleration (nv) [rad/s^2, m/s^2].

    Raises:
        ShapeError, NotFiniteError: wrong size or NaN/inf input.
        InvalidInputError: the torques overflow float64 (e.g. ``v = 1e300``; NaN before).
    """
    qa = robot.check_configuration(q)
    va = robot.check_velocity(v)
    aa = as_vector(a, robot.nv, "a")
    tau = np.asarray(pin.rnea(robot._model, robot._model.createData(), qa, va, aa))
    return finite_result(tau, "inverse dynamics", v=va, a=aa)


def gravity_torque(robot: Robot, q: Any) -> FloatArray:
    """``G(q) = NE(q, 0, 0)`` [N m, N]: the torques holding the robot still against gravity."""
    qa = robot.check_configuration(q)
    zero = np.zeros(robot.nv)
    return np.asarray(pin.rnea(robot._model, robot._model.createData(), qa, zero, zero))


def nonlinear_effects(robot: Robot, q: Any, v: Any) -> FloatArray:
    """``F(q, v) = C(q, v) v + G(q) = NE(q, v, 0)`` [N m, N] (slide 5:28).

    Raises InvalidInputError when ``F`` overflows float64 (NaN before).
    """
    qa = robot.check_configuration(q)
    va = robot.check_velocity(v)
    zero = np.zeros(robot.nv)
    out = np.asarray(pin.rnea(robot._model, robot._model.createData(), qa, va, zero))
    return finite_result(out, "nonlinear_effects", v=va)


def coriolis_torque(robot: Robot, q: Any, v: Any) -> FloatArray:
    """``C(q, v) v = NE(q, v, 0) - NE(q, 0, 0)`` [N m, N]: centripetal and Coriolis terms.

    Raises InvalidInputError when ``C v`` overflows float64 (NaN before).
    """
    qa = robot.check_configuration(q)
    va = robot.check_velocity(v)
    data = robot._model.createData()
    zero = np.zeros(robot.nv)
    out = np.asarray(pin.rnea(robot._model, data, qa, va, zero)) - np.asarray(
        pin.rnea(robot._model, data, qa, zero, zero)
    )
    return finite_result(out, "coriolis_torque", v=va)


def mass_matrix(robot: Robot, q: Any) -> FloatArray:
    """Joint-space inertia matrix from ``nv`` Newton-Euler calls: ``M e_i = NE(q, 0, e_i) - G``.

    Returns:
        ``M(q)``, symmetric positive definite (nv, nv) [kg m^2, kg].
    """
    qa = robot.check_configuration(q)
    model = robot._model
    data = model.createData()
    nv = robot.nv
    zero = np.zeros(nv)
    gravity = np.asarray(pin.rnea(model, data, qa, zero, zero))
    columns = np.empty((nv, nv))
    unit = np.zeros(nv)
    for i in range(nv):  # one recursion per column: the construction of slide 5:24
        unit[i] = 1.0
        columns[:, i] = np.asarray(pin.rnea(model, data, qa, zero, unit)) - gravity
        unit[i] = 0.0
    return columns
