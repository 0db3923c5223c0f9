"""Linearization of a robot's dynamics about an equilibrium (for LQR).

With the state ``x = (q (-) q_eq, v - v_eq)`` (tangent coordinates) and the input ``u``
acting on the actuated joints through the selection ``S`` (``tau = tau_eq + S^T u``):

``A = [[-1/2 ad(v_eq), I], [da/dq, da/dv]]``,  ``B = [[0], [M^-1 S^T]]``

where ``da/dq``, ``da/dv`` and ``M^-1 = da/dtau`` are the derivatives of the forward dynamics
``a = ABA(q, v, tau)`` (``pin.computeABADerivatives``, analytic, no finite differences), and
``-1/2 ad(v_eq)`` is the rate of ``q (-) q_eq`` on spherical and planar joints moving at
``v_eq`` (zero at rest and on vector-space or continuous joints).

Fixed-base robots only: a floating robot is not at an equilibrium without contacts.

Thread safety: :func:`linearize` builds its own Pinocchio data per call and may run from several
threads; a :class:`LinearizedSystem` is plain data that its users only read, so it may be shared as
long as nobody modifies its arrays.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector
from taskspace.dynamics.newton_euler import finite_result
from taskspace.errors import InvalidInputError, TaskspaceWarning

if TYPE_CHECKING:
    from taskspace.model.robot import Robot

EQUILIBRIUM_TOLERANCE = 1e-8
"""Largest ``|a(q_eq, v_eq, tau_eq)|`` [rad/s^2] accepted silently as an equilibrium."""


@dataclass
class LinearizedSystem:
    """``x' = A x + B u`` about ``(q_eq, v_eq, tau_eq)``.

    Attributes:
        A: (2 nv, 2 nv) system matrix.
        B: (2 nv, m) input matrix, ``m`` = number of actuated velocity coordinates.
        q_eq: equilibrium configuration (nq).
        v_eq: equilibrium velocity (nv) [rad/s] (usually zero).
        tau_eq: torques holding the equilibrium (nv) [N m].
        actuated: velocity indices of the actuated joints (m,).
        equilibrium_acceleration: ``a(q_eq, v_eq, tau_eq)`` (nv); ~0 at an equilibrium.
        robot_name: name of the robot it was linearized on (``None``: not recorded).
    """

    A: FloatArray
    B: FloatArray
    q_eq: FloatArray
    v_eq: FloatArray
    tau_eq: FloatArray
    actuated: np.ndarray
    equilibrium_acceleration: FloatArray
    robot_name: str | None = None

    @property
    def selection(self) -> FloatArray:
        """Selection matrix ``S`` (m x nv): ``u = S tau``."""
        nv = self.tau_eq.size
        return np.eye(nv)[self.actuated]


def _actuated_indices(robot: Robot, actuated: Sequence[str] | str | None) -> np.ndarray:
    if actuated is None:
        # the robot's actuated coordinates: all joints made the cart-pole's passive hinge an
        # input, and an LQR designed on it used a motor the robot does not have
        powered = np.flatnonzero(robot.effort_limits > 0)
        if not powered.size:
            raise InvalidInputError(
                f"'{robot.name}' has no actuated joint (every effort limit is 0): name the "
                f"inputs with actuated=[...]; joints: {', '.join(robot._model.names[1:])}"
            )
        return powered
    # One name is one joint (iterating "slider" looked up the joint 's').
    names: Any = [actuated] if isinstance(actuated, str) else actuated
    if isinstance(names, (bytes, bytearray)) or not isinstance(names, Iterable):
        raise InvalidInputError(
            f"actuated must be a joint name or a list of joint names, got {actuated!r}"
        )
    names = list(names)
    for name in names:
        if not isinstance(name, str):
            raise InvalidInputError(
                f"actuated must hold joint names (str), got {name!r} in {actuated!r}; "
                f"valid joints are: {', '.join(robot._model.names[1:])}"
            )
    idx: list[int] = []
    for name in names:
        jid = robot.joint_id(name)  # raises UnknownNameError listing the joints
        joint = robot._model.joints[jid]
        idx.extend(range(joint.idx_v, joint.idx_v + joint.nv))
    if not idx:
        raise InvalidInputError("actuated must name at least one joint")
    return np.asarray(sorted(set(idx)), dtype=int)


def _moving_frame_block(model: pin.Model, v: FloatArray, out: FloatArray) -> None:
    """Fill ``d/dx (Jlog(x) v)`` at ``x = 0`` (``-1/2 ad(v)``) on spherical and planar joints.

    The rate of ``x_1 = q (-) q_eq`` is ``Jlog(x_1) v``; on a non-commutative joint moving at
    ``v_eq`` its derivative is not zero (it was left 0: entries up to 0.45 missing at 1 rad/s).
    Zero at rest and on vector-space and continuous joints.
    """
    for joint in model.joints[1:]:
        kind, i = joint.shortname(), joint.idx_v
        if kind == "JointModelSpherical":  # so(3): -1/2 [w]x
            wx, wy, wz = v[i : i + 3]
            out[i : i + 3, i : i + 3] = -0.5 * np.array(
                [[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]]
            )
        elif kind == "JointModelPlanar":  # se(2), v = (vx, vy, w): -1/2 ad(v)
            vx, vy, w = v[i : i + 3]
            out[i : i + 2, i : i + 3] = 0.5 * np.array([[0.0, w, -vy], [-w, 0.0, vx]])


def linearize(
    robot: Robot,
    q_eq: Any,
    v_eq: Any = None,
    tau_eq: Any = None,
    *,
    actuated: Sequence[str] | str | None = None,
) -> LinearizedSystem:
    """Linearize ``q'' = ABA(q, v, tau)`` about an equilibrium (fixed-base robots).

    Args:
        robot: a fixed-base robot.
        q_eq: equilibrium configuration (nq).
        v_eq: equilibrium velocity (nv) [rad/s]; zero if omitted.
        tau_eq: equilibrium torques (nv) [N m]; default: gravity compensation
            ``G(q_eq)`` on the actuated joints, zero on the others.
        actuated: names of the actuated joints (``B`` has their columns only), or one name;
            if omitted, the robot's actuated joints (effort limit > 0: not the
            :attr:`~taskspace.model.Robot.passive_joints`). For the cart-pole: ``["slider"]``,
            ``"slider"`` or nothing (its hinge is passive).

    Raises:
        InvalidInputError: floating-base robot, bad sizes, ``actuated`` not names, no
            ``actuated`` given and no joint actuated, derivatives that overflow float64.
        UnknownNameError: an actuated joint does not exist.

    Warns:
        TaskspaceWarning: ``(q_eq, v_eq, tau_eq)`` is not an equilibrium (the unactuated
            joints cannot be held: e.g. the cart-pole's pole away from vertical).
    """
    if robot.is_floating:
        raise InvalidInputError(
            f"linearize supports fixed-base robots only; '{robot.name}' has a floating base"
        )
    model = robot._model
    data = model.createData()
    q = robot.check_configuration(q_eq, "q_eq")
    nv = robot.nv
    v = np.zeros(nv) if v_eq is None else robot.check_velocity(v_eq, "v_eq")
    idx = _actuated_indices(robot, actuated)
    if tau_eq is None:
        gravity = np.asarray(pin.computeGeneralizedGravity(model, data, q))
        tau = np.zeros(nv)
        tau[idx] = gravity[idx]
        if v_eq is not None:
            nle = np.asarray(pin.nonLinearEffects(model, data, q, v))
            tau[idx] = nle[idx]
    else:
        tau = as_vector(tau_eq, nv, "tau_eq")
    ddq_dq, ddq_dv, minv = pin.computeABADerivatives(model, data, q, v, tau)
    minv = np.triu(minv) + np.triu(minv, 1).T
    a_eq = np.asarray(data.ddq).copy()
    # (a point is an equilibrium when a = 0; before, any v_eq without a zero entry silenced
    # the warning, whatever the acceleration)
    if float(np.max(np.abs(a_eq))) > EQUILIBRIUM_TOLERANCE:
        warnings.warn(
            f"linearize: ({robot.name}) is not at an equilibrium, |a(q_eq, v_eq, tau_eq)| = "
            f"{float(np.max(np.abs(a_eq))):.3g} rad/s^2; the linear model is the first-order "
            "expansion about a moving point",
            TaskspaceWarning,
            stacklevel=2,
        )
    finite_result(ddq_dq, "linearize: da/dq", v_eq=v, tau_eq=tau)  # NaN A/B before
    finite_result(ddq_dv, "linearize: da/dv", v_eq=v, tau_eq=tau)
    A = np.zeros((2 * nv, 2 * nv))
    _moving_frame_block(model, v, A[:nv, :nv])
    A[:nv, nv:] = np.eye(nv)
    A[nv:, :nv] = ddq_dq
    A[nv:, nv:] = ddq_dv
    B = np.zeros((2 * nv, idx.size))
    B[nv:, :] = minv[:, idx]
    return LinearizedSystem(
        A=A,
        B=B,
        q_eq=q,
        v_eq=v,
        tau_eq=tau,
        actuated=idx,
        equilibrium_acceleration=a_eq,
        robot_name=robot.name,
    )
