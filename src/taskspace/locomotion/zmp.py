"""Zero moment point (ZMP) and center of pressure (CoP).

The contact wrench ``(f, tau_O)`` (total force and moment about the world origin) of every
contact together, on a horizontal ground at height ``z_p``, has zero horizontal moment about
the ZMP ``p``:

    tau_p = tau_O - p x f,   (tau_p)_x = (tau_p)_y = 0
    =>  p_x = (z_p f_x - tau_O,y) / f_z,   p_y = (z_p f_y + tau_O,x) / f_z.

Two ways to get the wrench:

* from the contact wrenches: ``f = sum_i f_i``, ``tau_O = sum_i (tau_i + p_i x f_i)``;
* from the full dynamics (Newton-Euler of the whole robot): the contacts are the only
  external forces besides gravity, so with the centroidal momentum ``h_G = (m cdot, L_G)``
  (Pinocchio: ``computeCentroidalMomentumTimeVariation``),

      f = m (cddot - g),   tau_O = dL_G/dt + c x f.

On flat ground with unilateral contacts the two agree and the ZMP is the CoP of the total
ground reaction, inside the support polygon. The CoP of one foot is the same formula applied
to that foot's wrench in its sole frame: ``p = (-tau_y / f_z, tau_x / f_z)`` at the sole.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_scalar, as_vector
from taskspace.errors import InvalidInputError

GRAVITY = np.array([0.0, 0.0, -9.81])


@dataclass(frozen=True)
class ContactWrench:
    """A contact wrench in world coordinates.

    Attributes:
        point: application point [m] (world).
        force: force [N] (world axes).
        torque: moment about ``point`` [N m] (world axes); zero for a point contact.
    """

    point: FloatArray
    force: FloatArray
    torque: FloatArray

    def __post_init__(self) -> None:
        # finite 3-vectors (copies), whichever way the wrench is made: a NaN force would
        # otherwise give a NaN ZMP silently
        for name in ("point", "force", "torque"):
            object.__setattr__(self, name, as_vector(getattr(self, name), 3, name).copy())

    @staticmethod
    def point_force(point: Any, force: Any) -> ContactWrench:
        """A pure force at a point (a point contact)."""
        return ContactWrench(point, force, np.zeros(3))

    @staticmethod
    def from_local(placement: pin.SE3, wrench: Any) -> ContactWrench:
        """A 6-D wrench ``(f, tau)`` expressed in a contact frame (LOCAL), about its origin."""
        w = as_vector(wrench, 6, "wrench")
        R = placement.rotation
        return ContactWrench(placement.translation.copy(), R @ w[:3], R @ w[3:])

    def moment_about_origin(self) -> FloatArray:
        """``tau + p x f`` [N m]."""
        return np.asarray(self.torque + np.cross(self.point, self.force))


def _zmp(force: FloatArray, torque_origin: FloatArray, height: float) -> FloatArray:
    fz = float(force[2])
    if fz <= 1e-9 * max(1.0, float(np.linalg.norm(force))):
        raise InvalidInputError(
            f"the vertical contact force is {fz:.3g} N: the ZMP exists only while the ground "
            "pushes up (f_z > 0); the robot is in flight or pulled down"
        )
    return np.array(
        [
            (height * force[0] - torque_origin[1]) / fz,
            (height * force[1] + torque_origin[0]) / fz,
            height,
        ]
    )


def total_wrench(wrenches: Sequence[ContactWrench]) -> tuple[FloatArray, FloatArray]:
    """``(f, tau_O)``: the sum of the contact forces and their moment about the origin."""
    if not wrenches:
        raise InvalidInputError("no contact wrenches: the ZMP needs at least one contact")
    for i, w in enumerate(wrenches):
        if not isinstance(w, ContactWrench):
            raise InvalidInputError(
                f"wrenches[{i}] must be a ContactWrench (ContactWrench.point_force(point, "
                f"force), ContactWrench.from_local(placement, wrench)), got {type(w).__name__}"
            )
    with np.errstate(over="ignore", invalid="ignore"):
        f = np.sum([w.force for w in wrenches], axis=0)
        tau = np.sum([w.moment_about_origin() for w in wrenches], axis=0)
    if not (np.isfinite(f).all() and np.isfinite(tau).all()):
        raise InvalidInputError(
            "the contact wrenches' total force or moment overflows (inf): the forces or "
            "points are too large (give them in N and m)"
        )
    return f, tau


def zmp_from_wrenches(wrenches: Sequence[ContactWrench], height: float = 0.0) -> FloatArray:
    """ZMP [m] (a 3-vector on the plane ``z = height``) of a set of contact wrenches."""
    f, tau = total_wrench(wrenches)
    return _zmp(f, tau, as_scalar(height, "height"))


def contact_wrench_from_dynamics(
    robot: Any, q: Any, v: Any, a: Any, gravity: Any = GRAVITY
) -> tuple[FloatArray, FloatArray]:
    """Total contact wrench ``(f, tau_O)`` implied by the motion ``(q, v, a)``.

    ``f = m (cddot - g)`` and ``tau_O = dL_G/dt + c x f`` (centroidal momentum rate).
    """
    model = robot._model
    q = robot.check_configuration(q)
    v = as_vector(v, model.nv, "v")
    a = as_vector(a, model.nv, "a")
    g = as_vector(gravity, 3, "gravity")
    data = model.createData()
    dhg = pin.computeCentroidalMomentumTimeVariation(model, data, q, v, a)
    com = data.com[0]
    mass = data.mass[0]
    f = dhg.linear - mass * g
    tau = dhg.angular + np.cross(com, f)
    return np.asarray(f), np.asarray(tau)


def zmp_from_dynamics(
    robot: Any, q: Any, v: Any, a: Any, height: float = 0.0, gravity: Any = GRAVITY
) -> FloatArray:
    """ZMP [m] on the plane ``z = height`` from the robot's motion (see the module docstring).

    Args:
        robot: a floating-base :class:`~taskspace.model.Robot`.
        q, v, a: configuration, velocity [rad/s, m/s] and acceleration.
        height: ground height [m].
        gravity: gravity vector [m/s^2].
    """
    f, tau = contact_wrench_from_dynamics(robot, q, v, a, gravity)
    return _zmp(f, tau, as_scalar(height, "height"))


def center_of_pressure(wrench: Any, placement: pin.SE3 | None = None) -> FloatArray:
    """Center of pressure of one foot.

    Args:
        wrench: ``(f, tau)`` in the sole frame (LOCAL, z normal), about the frame origin.
        placement: the sole frame in the world; when given the CoP is returned in the world.

    Returns:
        The CoP ``(-tau_y / f_z, tau_x / f_z, 0)`` in the sole frame, or mapped to the world.
    """
    w = as_vector(wrench, 6, "wrench")
    cop = _zmp(w[:3], w[3:], 0.0)
    if placement is None:
        return cop
    return np.asarray(placement.act(cop))
