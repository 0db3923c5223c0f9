"""Rigid contacts for inverse dynamics: 6-D (flat foot) and point contacts, linearized cones.

A contact adds force variables ``f`` (its ``force_dim`` entries), the rigid-contact
acceleration constraint ``J_c a + Jdot_c v = -kp e_c - kd J_c v`` (zero contact acceleration
with Baumgarte stabilization of drift), the force's share ``J_c^T f`` in the dynamics, and
friction-cone inequalities ``K f >= k``.

* :class:`Contact6D`: wrench ``(f, tau)`` in the contact frame (LOCAL; z is the normal):
  ``|f_x|, |f_y| <= mu / sqrt(2) f_z`` (inner pyramid of the cone), ``f_z >= f_min``,
  center of pressure inside the sole rectangle ``|tau_x| <= w f_z``, ``|tau_y| <= l f_z``, and
  ``|tau_z| <= mu (l + w) f_z`` (a conservative yaw-torque bound).
* :class:`PointContact`: force in world coordinates with normal ``+z`` (flat ground),
  ``|f_x|, |f_y| <= mu / sqrt(2) f_z``, ``f_z >= f_min``.

Thread safety: a constraint keeps no per-step workspace besides immutable caches replaced at
once (e.g. the velocity box for the last ``dt``), and reads the :class:`~taskspace.model.State`
it is given, so one constraint may serve solvers in several threads. What it derives from the
robot (limits, collision pairs, compiled rows) is rebuilt on the next call after a model or
world change; do not change the robot, the world or the constraint's parameters (bounds, gains,
margins) while another thread steps with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


_FIXED = frozenset(
    {
        "robot",
        "frame",
        "frame_id",
        "friction",
        "min_force",
        "max_force",
        "half_length",
        "half_width",
    }
)
"""Contact attributes that cannot change after construction (see ``Contact.__setattr__``)."""


def _check_reference(frame: str, value: object) -> pin.SE3:
    """A contact reference: a ``pin.SE3`` with a finite translation and a rotation matrix."""
    if not isinstance(value, pin.SE3):
        raise InvalidInputError(
            f"reference of contact '{frame}' must be a pinocchio.SE3 or None (or use "
            f"set_reference(state)), got {type(value).__name__}"
        )
    R, p = np.asarray(value.rotation), np.asarray(value.translation)
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(p))):
        raise InvalidInputError(f"reference of contact '{frame}' has non-finite entries")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InvalidInputError(
            f"reference of contact '{frame}': its rotation is not a rotation matrix "
            f"(R^T R != I or det R < 0)"
        )
    return value.copy()


class Contact:
    """Base class of rigid contacts (see the module docstring).

    Attributes:
        robot: the robot.
        frame: contact frame name.
        friction: Coulomb coefficient ``mu``.
        min_force: smallest normal force [N] (unilaterality with a margin).
        max_force: largest normal force [N] (``None``: unbounded), one more row of the cone.
        kp, kd: Baumgarte gains on the contact's position and velocity error [1/s^2, 1/s].
        force_dim: number of force variables (6 or 3).
    """

    force_dim: int
    _K: FloatArray
    _k: FloatArray

    def __init__(
        self,
        robot: Robot,
        frame: str,
        friction: float = 0.7,
        min_force: float = 1.0,
        kp: float = 0.0,
        kd: float = 20.0,
        max_force: float | None = None,
    ) -> None:
        self.robot = robot
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.friction = check_positive(friction, "friction")
        self.min_force = check_positive(min_force, "min_force", strict=False)
        self.kp = check_positive(kp, "kp", strict=False)
        self.kd = check_positive(kd, "kd", strict=False)
        self.name = f"contact({frame})"
        limit = None if max_force is None else check_positive(max_force, "max_force")
        if limit is not None and limit < self.min_force:
            raise InvalidInputError(
                f"contact '{frame}': max_force ({limit:g} N) must be >= min_force "
                f"({self.min_force:g} N)"
            )
        self.max_force: float | None = limit
        self.reference: pin.SE3 | None = None

    def __setattr__(self, name: str, value: object) -> None:
        """Validate the gains (finite, ``>= 0``); the cone's parameters are fixed once set."""
        if name in ("kp", "kd"):
            value = check_positive(value, f"{name} of contact '{self.frame}'", strict=False)
        elif name == "reference" and value is not None:
            value = _check_reference(self.frame, value)
        elif name in _FIXED and name in self.__dict__:
            raise InvalidInputError(
                f"contact '{self.frame}': {name} is fixed at construction (the friction cone "
                f"and the controllers' constraint rows are built from it); create a new "
                f"{type(self).__name__}"
            )
        object.__setattr__(self, name, value)

    def set_reference(self, state: State) -> None:
        """Anchor the contact where the frame is now (the Baumgarte position reference)."""
        robot = getattr(state, "robot", None)
        if robot is not self.robot:
            raise InvalidInputError(
                f"contact '{self.frame}' is defined on robot '{self.robot.name}'; "
                f"set_reference needs a state of that robot (robot.state(q)), got "
                f"{type(state).__name__} of {getattr(robot, 'name', robot)!r}"
            )
        self.reference = state.frame_placement(self.frame_id).copy()

    def jacobian(self, state: State) -> FloatArray:
        """(force_dim, nv) contact Jacobian."""
        raise NotImplementedError

    def drift(self, state: State) -> FloatArray:
        """Contact acceleration at zero joint acceleration, ``Jdot_c v``."""
        raise NotImplementedError

    def position_error(self, state: State) -> FloatArray:
        """Drift of the contact from its reference (``set_reference``), same rows as ``J_c``."""
        raise NotImplementedError

    def acceleration_rhs(self, state: State) -> FloatArray:
        """Right-hand side ``b`` of ``J_c a = b``: ``-Jdot_c v - kd J_c v - kp e_c``."""
        rhs = -self.drift(state)
        if self.kd:
            rhs -= self.kd * self.jacobian(state).dot(state.v)
        if self.kp and self.reference is not None:
            rhs -= self.kp * self.position_error(state)
        return np.asarray(rhs)

    def cone(self) -> tuple[FloatArray, FloatArray]:
        """``(K, k)`` with the linearized friction cone ``K f >= k``.

        With ``max_force`` the last row is ``-f_n >= -max_force`` (``f_n``: the normal force).
        """
        return self._K, self._k

    def _with_max_force(self, normal: int) -> None:
        """Append ``-f[normal] >= -max_force`` to the cone when ``max_force`` is set."""
        if self.max_force is None:
            return
        row = np.zeros((1, self.force_dim))
        row[0, normal] = -1.0
        self._K = np.vstack([self._K, row])
        self._k = np.append(self._k, -self.max_force)

    def wrench_in_world(self, state: State, f: FloatArray) -> FloatArray:
        """Contact force (and torque) in world coordinates, for display."""
        raise NotImplementedError

    def normal_force(self, f: FloatArray) -> float:
        """The normal force ``f_n`` [N] of this contact's force variables ``f``."""
        return float(f[2])

    @property
    def max_force_row(self) -> int | None:
        """Index of the row ``-f_n >= -max_force`` in :meth:`cone` (``None`` without it)."""
        return None if self.max_force is None else len(self._k) - 1

    @property
    def normal_force_limit(self) -> float | None:
        """The current upper bound of the normal force [N] (``max_force`` unless lowered).

        A contact transition (lift-off, touchdown) lowers it for a while with
        :meth:`set_normal_force_limit`, as TSID's contact transitions lower the contact's
        maximum normal force: :class:`~taskspace.control.InverseDynamicsQP` reads it at every
        step (weighted and hierarchical), so the force ramps, while :meth:`cone` keeps
        ``max_force``.
        """
        limit = self.__dict__.get("_limit")
        return self.max_force if limit is None else float(limit)

    @property
    def max_normal_force(self) -> float | None:
        """The upper bound of the normal force [N] now (same as :attr:`normal_force_limit`).

        Assigning it is :meth:`set_normal_force_limit` (validated: in ``[min_force,
        max_force]``; ``None`` restores ``max_force``).
        """
        return self.normal_force_limit

    @max_normal_force.setter
    def max_normal_force(self, value: float | None) -> None:
        self.set_normal_force_limit(value)

    def set_normal_force_limit(self, value: float | None) -> None:
        """Bound the normal force by ``value`` [N] in ``[min_force, max_force]``.

        ``None`` restores ``max_force``. Needs a contact built with ``max_force`` (its cone
        has the bound's row).
        """
        if value is None:
            object.__setattr__(self, "_limit", None)
            return
        if self.max_force is None:
            raise InvalidInputError(
                f"contact '{self.frame}': a normal-force limit needs a contact built with "
                "max_force (its cone then has the bound's row)"
            )
        limit = check_positive(value, f"normal-force limit of contact '{self.frame}'", strict=False)
        if not (self.min_force <= limit <= self.max_force):
            raise InvalidInputError(
                f"contact '{self.frame}': normal-force limit {limit:g} N outside "
                f"[min_force, max_force] = [{self.min_force:g}, {self.max_force:g}] N"
            )
        object.__setattr__(self, "_limit", limit)

    def regularization_weights(self) -> FloatArray:
        """Relative weights of the force variables in the force regularization."""
        return np.ones(self.force_dim)

    def compiled_kind(self) -> str | None:
        """How the compiled inverse-dynamics kernel evaluates this contact (``None``: it does not).

        A contact class the kernel serves declares it itself (``"contact6d"``: LOCAL Jacobian
        and spatial drift, ``log6`` position error; ``"point"``: linear LOCAL_WORLD_ALIGNED
        rows and classical drift, ``p - p_ref``); a subclass that declares nothing (it may
        change the Jacobian or the drift) takes the Python path (see :func:`compiled_kind`).
        """
        return None


class Contact6D(Contact):
    """A flat rectangular contact (foot sole) with a 6-D wrench in the contact frame.

    Args:
        robot: the robot.
        frame: sole frame (z axis normal to the ground, origin at the sole center).
        half_length: half sole length along x [m].
        half_width: half sole width along y [m].
        friction: Coulomb coefficient.
        min_force: smallest normal force [N].
        kp, kd: Baumgarte gains.
        max_force: largest normal force ``f_z`` [N] (``None``: unbounded).
    """

    force_dim = 6

    def __init__(
        self,
        robot: Robot,
        frame: str,
        half_length: float = 0.1,
        half_width: float = 0.05,
        friction: float = 0.7,
        min_force: float = 1.0,
        kp: float = 0.0,
        kd: float = 20.0,
        max_force: float | None = None,
    ) -> None:
        super().__init__(robot, frame, friction, min_force, kp, kd, max_force)
        self.half_length = check_positive(half_length, "half_length")
        self.half_width = check_positive(half_width, "half_width")
        mu = self.friction / np.sqrt(2.0)
        lx, ly = self.half_length, self.half_width
        # rows of K f >= k on (fx, fy, fz, tx, ty, tz)
        K = [
            [-1, 0, mu, 0, 0, 0],
            [1, 0, mu, 0, 0, 0],
            [0, -1, mu, 0, 0, 0],
            [0, 1, mu, 0, 0, 0],
            [0, 0, 1, 0, 0, 0],
            [0, 0, ly, -1, 0, 0],
            [0, 0, ly, 1, 0, 0],
            [0, 0, lx, 0, -1, 0],
            [0, 0, lx, 0, 1, 0],
            [0, 0, self.friction * (lx + ly), 0, 0, -1],
            [0, 0, self.friction * (lx + ly), 0, 0, 1],
        ]
        self._K = np.array(K, dtype=float)
        self._k = np.zeros(len(K))
        self._k[4] = self.min_force
        self._with_max_force(2)

    def jacobian(self, state: State) -> FloatArray:
        """LOCAL frame Jacobian (6 x nv)."""
        return state.frame_jacobian_local(self.frame_id)

    def drift(self, state: State) -> FloatArray:
        """Body spatial acceleration at zero joint acceleration (LOCAL)."""
        return state.frame_drift_local(self.frame_id)

    def position_error(self, state: State) -> FloatArray:
        """``log6(T_ref^-1 T)``."""
        if self.reference is None:
            return np.zeros(6)
        return np.asarray(
            pin.log6(self.reference.actInv(state.frame_placement(self.frame_id))).vector
        )

    def regularization_weights(self) -> FloatArray:
        """Torques weighted by the inverse squared sole half-sizes [1/m^2].

        A torque ``tau_x`` costs as much as the normal-force difference ``tau_x / w`` between
        the sole edges that would produce it, so the QP prefers shifting normal forces to
        pushing the center of pressure toward the sole's edges.
        """
        lx, ly = self.half_length, self.half_width
        return np.array([1.0, 1.0, 1.0, 1.0 / ly**2, 1.0 / lx**2, 1.0 / (lx**2 + ly**2)])

    def compiled_kind(self) -> str | None:
        """The kernel evaluates the LOCAL Jacobian, the spatial drift and ``log6``."""
        return "contact6d"

    def wrench_in_world(self, state: State, f: FloatArray) -> FloatArray:
        """Force and torque at the contact frame origin, world coordinates."""
        R = state.frame_placement(self.frame_id).rotation
        return np.concatenate([R @ f[:3], R @ f[3:]])


class PointContact(Contact):
    """A point contact (quadruped foot) on flat ground, force in world coordinates.

    Args:
        robot: the robot.
        frame: foot frame.
        friction: Coulomb coefficient.
        min_force: smallest normal force [N].
        kp, kd: Baumgarte gains.
        max_force: largest normal force ``f_z`` (world vertical) [N] (``None``: unbounded).
    """

    force_dim = 3

    def __init__(
        self,
        robot: Robot,
        frame: str,
        friction: float = 0.7,
        min_force: float = 1.0,
        kp: float = 0.0,
        kd: float = 20.0,
        max_force: float | None = None,
    ) -> None:
        super().__init__(robot, frame, friction, min_force, kp, kd, max_force)
        mu = self.friction / np.sqrt(2.0)
        self._K = np.array(
            [[-1, 0, mu], [1, 0, mu], [0, -1, mu], [0, 1, mu], [0, 0, 1]], dtype=float
        )
        self._k = np.array([0, 0, 0, 0, self.min_force], dtype=float)
        self._with_max_force(2)

    def jacobian(self, state: State) -> FloatArray:
        """Linear rows of the LOCAL_WORLD_ALIGNED Jacobian (3 x nv)."""
        return state.frame_jacobian(self.frame_id)[:3]

    def drift(self, state: State) -> FloatArray:
        """Classical acceleration of the foot at zero joint acceleration (world)."""
        return state.frame_drift(self.frame_id)[:3]

    def position_error(self, state: State) -> FloatArray:
        """``p - p_ref`` [m]."""
        if self.reference is None:
            return np.zeros(3)
        return np.asarray(
            state.frame_placement(self.frame_id).translation - self.reference.translation
        )

    def compiled_kind(self) -> str | None:
        """The kernel evaluates the linear world-aligned rows and the classical drift."""
        return "point"

    def wrench_in_world(self, state: State, f: FloatArray) -> FloatArray:
        """The force (already in world coordinates) and a zero torque."""
        return np.concatenate([f, np.zeros(3)])


def compiled_kind(contact: Contact) -> str | None:
    """The kind ``type(contact)`` itself declares (``None``: the Python path serves it)."""
    method = type(contact).__dict__.get("compiled_kind")
    return None if method is None else method(contact)  # type: ignore[no-any-return]
