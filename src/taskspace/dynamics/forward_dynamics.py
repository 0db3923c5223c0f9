"""Forward dynamics ``q'' = M(q)^-1 (u + tau_friction(v) - F(q, v))`` through Pinocchio's ABA.

Slide 5:29: "if we know which torques u we apply, use q''* = M(q)^-1 (u - F(q, q')) to
simulate the dynamics of the system". Pinocchio's articulated-body algorithm (``pin.aba``)
computes this in O(n) without forming ``M``; this module adds optional joint friction (viscous
damping and smoothed Coulomb friction) on top.

Thread safety: :class:`JointFriction` is an immutable value; :class:`ForwardDynamics` gives
each thread its own Pinocchio data (see there); :func:`forward_dynamics` builds its own.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_float_array, as_vector, check_positive
from taskspace.dynamics.newton_euler import finite_result
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot


@dataclass(frozen=True, kw_only=True)
class JointFriction:
    """Joint friction added to the applied torques by the simulator.

    ``tau_friction(v) = -damping * v - coulomb * tanh(v / coulomb_smoothing)``

    The Coulomb term is the smooth approximation of ``-coulomb * sign(v)`` (an ODE with a
    discontinuous right-hand side would break the error bounds of the integrators). Friction
    acts on the joints only, never on the base: a free-flyer (its first 6 velocity entries)
    or a planar base (``Robot.load(..., base="planar")``: its first 3, x, y and yaw) moves
    without joint friction. A coefficient vector has one entry per velocity coordinate of
    the joints after the base (``robot.nv - 6``, ``robot.nv - 3`` or ``robot.nv``; a spherical
    joint has 3).

    Attributes:
        damping: viscous coefficient, scalar or one per joint velocity coordinate
            [N m s/rad or N s/m].
        coulomb: Coulomb friction magnitude, scalar or one per joint velocity coordinate
            [N m or N].
        coulomb_smoothing: velocity scale of the ``tanh`` smoothing [rad/s or m/s].
    """

    damping: float | tuple[float, ...] = 0.0
    coulomb: float | tuple[float, ...] = 0.0
    coulomb_smoothing: float = 1e-2

    @property
    def is_zero(self) -> bool:
        """No friction at all."""
        return not np.any(np.asarray(self.damping)) and not np.any(np.asarray(self.coulomb))


LIE_GROUP_JOINTS = frozenset(
    {"JointModelFreeFlyer", "JointModelSpherical", "JointModelPlanar", "JointModelComposite"}
)
"""Pinocchio joints whose ``integrate`` is not a sum in the tangent coordinates (SE(3), SO(3),
SE(2); composite joints may hold one): :func:`~taskspace.dynamics.rk4_step` maps its stage
velocities through ``dexp^-1`` there (``pin.dIntegrate``). The unit complex numbers of
continuous joints (SO(2)) commute: their stages need nothing."""


def _coefficients(value: Any, size: int, name: str, count: str) -> FloatArray:
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        arr = np.full(size, float(arr))
    else:
        arr = as_vector(arr, size, f"{name} {count}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise InvalidInputError(f"{name} must be finite and >= 0, got {value!r}")
    return arr


class ForwardDynamics:
    """Joint accelerations from torques: ``a = ABA(q, v, u + tau_friction(v))``.

    The object keeps its own ``pin.Data`` so that evaluating it does not disturb other users
    of the robot. :meth:`acceleration` does no validation (hot path of the integrators); use
    :func:`forward_dynamics` for a checked one-off evaluation.

    Args:
        robot: the robot.
        friction: joint friction (none by default).

    Thread safety: :meth:`acceleration` may be called from several threads on one object:
    ``data`` is used by the thread that built the object, every other thread gets its own
    ``pin.Data`` on its first call. The coefficients are read-only.
    """

    def __init__(self, robot: Robot, friction: JointFriction | None = None) -> None:
        self.robot = robot
        self._model = robot._model  # the robot's own: never handed out (see ``model``)
        self.data = robot._model.createData()
        self._owner = threading.get_ident()
        self._local = threading.local()
        friction = friction or JointFriction()
        self.friction = friction
        nv = robot.nv
        start = robot.base_nv
        n_joints = nv - start
        self._start = start
        what = (
            f"(one per velocity coordinate of the joints after the {start}-dof base)"
            if start
            else "(one per velocity coordinate)"
        )
        self._damping = _coefficients(friction.damping, n_joints, "friction damping", what)
        self._coulomb = _coefficients(friction.coulomb, n_joints, "friction coulomb", what)
        self._smoothing = check_positive(friction.coulomb_smoothing, "coulomb_smoothing")
        self._has_friction = bool(np.any(self._damping) or np.any(self._coulomb))
        self._has_coulomb = bool(np.any(self._coulomb))
        # joints whose configuration space is a non-commutative Lie group (q (+) v is not
        # q + v in any chart): the RK4 stages need dexp^-1 there (see integrators._stage_rate)
        # each with a model holding only that joint, whose dIntegrate is the joint's block
        self._lie_joints: list[tuple[pin.Model, int, int, int]] = []
        for j in self._model.joints[1:]:
            if j.shortname() in LIE_GROUP_JOINTS:
                alone = pin.Model()
                alone.addJoint(0, j, pin.SE3.Identity(), "alone")
                self._lie_joints.append((alone, j.idx_q, j.nq, j.idx_v))

    @property
    def model(self) -> pin.Model:
        """``robot.model``: the robot's read-only copy (edit through :meth:`Robot.edit_model`)."""
        return self.robot.model

    @property
    def has_friction(self) -> bool:
        """Whether any friction coefficient is non-zero."""
        return self._has_friction

    def friction_torque(self, v: FloatArray) -> FloatArray:
        """``-damping v - coulomb tanh(v / smoothing)`` (zero on the base) [N m or N]."""
        out = np.zeros(self._model.nv)
        vj = v[self._start :]
        f = -self._damping * vj
        if self._has_coulomb:
            f -= self._coulomb * np.tanh(vj / self._smoothing)
        out[self._start :] = f
        return out

    def acceleration(self, q: FloatArray, v: FloatArray, tau: FloatArray) -> FloatArray:
        """``q'' = M^-1 (tau + tau_friction(v) - C(q, v) v - G(q))`` [rad/s^2, m/s^2].

        Args:
            q: configuration (nq), unchecked.
            v: velocity (nv) [rad/s, m/s], unchecked.
            tau: applied joint torques (nv) [N m, N], unchecked.
        """
        if self._has_friction:
            tau = tau + self.friction_torque(v)
        data = self.data if threading.get_ident() == self._owner else self._thread_data()
        return np.asarray(pin.aba(self._model, data, q, v, tau))

    def _thread_data(self) -> Any:
        """The calling thread's ``pin.Data`` (made on its first call)."""
        data = self._local.__dict__.get("data")
        if data is None:
            data = self._local.data = self._model.createData()
        return data


def forward_dynamics(
    robot: Robot, q: Any, v: Any, tau: Any, friction: JointFriction | None = None
) -> FloatArray:
    """Validated one-off forward dynamics ``q'' = M(q)^-1 (u - F(q, v))`` (slide 5:29).

    Args:
        robot: the robot.
        q: configuration (nq).
        v: velocity (nv) [rad/s, m/s].
        tau: applied torques ``u`` (nv) [N m, N].
        friction: optional joint friction added to ``u``.

    Returns:
        The joint accelerations (nv) [rad/s^2, m/s^2].

    Raises:
        ShapeError, NotFiniteError: wrong size or NaN/inf input.
        InvalidInputError: the accelerations overflow float64 (``v = 1e300``; NaN before).
    """
    qa = robot.check_configuration(q)
    va = robot.check_velocity(v)
    ta = as_vector(tau, robot.nv, "tau")
    a = ForwardDynamics(robot, friction).acceleration(qa, va, ta)
    return finite_result(a, "forward dynamics", v=va, tau=ta)
