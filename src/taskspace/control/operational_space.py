"""Operational-space control in closed form (slides 5:31-5:35).

``u* = argmin_u |phi''(q) - y''*|^2_C + |u|^2_H`` with ``phi'' = J q'' + Jdot v`` and
``q'' = M^-1 (u - F)``:

``u* = T# (y''* - Jdot v + T F)``, ``T = J M^-1``, ``T# = (T^T C T + H)^-1 T^T C``

(slide 5:33; in the limit ``C -> inf``, ``T# = H^-1 T^T (T H^-1 T^T)^-1``). The slide writes
``2 Jdot v`` after approximating ``J'' = 0``; here the drift is the exact ``Jdot v`` of the
feature (``phi'' = J q'' + Jdot v`` holds exactly), so the task acceleration follows
``y''*`` exactly when ``C -> inf``. Several tasks are stacked into one big task map
(slide 5:35), each weighted by its precision ``rho`` (``C = diag(rho)``). The desired task
acceleration is the PD law of slide 5:34, ``y''* = y''_ref + Kp (y_ref - y) + Kd (y'_ref - y')``,
taken from each :class:`~taskspace.tasks.Task` (its ``kp``, ``kd``, target and reference).

Fixed-base robots with every joint actuated only (``u`` is the full joint torque). The QP
version with torque limits and contacts is :mod:`taskspace.control.inverse_dynamics_qp`.

Thread safety: :func:`operational_space_control` keeps its state local to the call (with a
:class:`~taskspace.model.State` per thread); :class:`OperationalSpaceController` serializes its
calls with a lock (see there); :class:`OperationalSpaceOptions` and :class:`OperationalSpaceStatus`
are immutable; an :class:`OperationalSpaceResult` is plain result data, not locked.
"""

from __future__ import annotations

import enum
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from taskspace._validation import FloatArray, as_vector, check_positive
from taskspace.errors import InvalidInputError, SolverError
from taskspace.qp.rows import TaskRowStack

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State
    from taskspace.tasks import Task


class OperationalSpaceStatus(enum.Enum):
    """Outcome of an operational-space step."""

    SOLVED = "solved"


@dataclass(frozen=True, kw_only=True)
class OperationalSpaceOptions:
    """Settings of :func:`operational_space_control`.

    Attributes:
        torque_weight: ``H`` of ``|u|^2_H``: a scalar (``H = h I``) or one value per joint
            [1/(N m)^2 relative to the task precisions]. Must be > 0 unless ``hard_tasks``.
        hard_tasks: use the limit ``C -> inf``: ``T# = H^-1 T^T (T H^-1 T^T)^-1`` (the tasks
            are met exactly; needs ``T`` of full row rank).
    """

    torque_weight: float | tuple[float, ...] = 1e-6
    hard_tasks: bool = False


@dataclass
class OperationalSpaceResult:
    """Result of one operational-space step.

    Attributes:
        success: a torque was computed.
        status: see :class:`OperationalSpaceStatus`.
        tau: joint torques ``u*`` (nv) [N m].
        a: joint accelerations they produce, ``M^-1 (u* - F)`` (nv) [rad/s^2].
        task_acceleration_errors: ``|J a + Jdot v - y''*|`` per task (by task name) [m/s^2 or
            rad/s^2] (unweighted).
        solve_time: wall time of the step [s].
    """

    success: bool
    status: OperationalSpaceStatus
    tau: FloatArray
    a: FloatArray
    task_acceleration_errors: dict[str, float] = field(default_factory=dict)
    solve_time: float = 0.0


def _torque_weight(options: OperationalSpaceOptions, nv: int) -> FloatArray:
    h = np.asarray(options.torque_weight, dtype=float)
    if h.ndim == 0:
        val = float(h)
        if options.hard_tasks:
            check_positive(val, "torque_weight")
        else:
            check_positive(val, "torque_weight (H of |u|^2_H)")
        return np.full(nv, val)
    h = as_vector(h, nv, "torque_weight")
    if np.any(h <= 0):
        raise InvalidInputError(f"torque_weight must be > 0 per joint, got {options.torque_weight}")
    return h


def _require_actuated(robot: Robot, what: str) -> None:
    """Refuse a floating base or passive joints (``u`` is the torque of every joint)."""
    if robot.is_floating:
        raise InvalidInputError(
            f"{what} needs a fixed-base robot; '{robot.name}' has a floating "
            "base: use taskspace.control.inverse_dynamics_qp"
        )
    if robot.passive_joints:
        # a torque on them was returned silently (the cart-pole's hinge has no motor)
        raise InvalidInputError(
            f"{what} needs every joint actuated; '{robot.name}' has passive joints "
            f"{list(robot.passive_joints)} (effort limit 0): use taskspace.control."
            "inverse_dynamics_qp (unactuated rows)"
        )


def _options(options: Any) -> OperationalSpaceOptions:
    if options is None:
        return OperationalSpaceOptions()
    if not isinstance(options, OperationalSpaceOptions):  # a dict: bare AttributeError
        raise InvalidInputError(
            f"options must be an OperationalSpaceOptions, got {type(options).__name__}"
        )
    return options


def operational_space_control(
    state: State, tasks: Sequence[Task], options: OperationalSpaceOptions | None = None
) -> OperationalSpaceResult:
    """Closed-form operational-space torques ``u* = T# (y''* - Jdot v + T F)`` (slide 5:33).

    Args:
        state: the robot state, created with the velocity (``robot.state(q, v)``) so that the
            features can give their drift ``Jdot v``.
        tasks: one or more tasks (stacked, slide 5:35), each with a target, weight ``rho``
            (``C``), ``kp`` [1/s^2] and ``kd`` [1/s].
        options: ``H`` and the hard-task limit.

    Returns:
        The torques, the joint accelerations they produce and the per-task errors.

    Raises:
        InvalidInputError: no tasks, floating-base robot or passive joints, state without
            velocity, task of another robot, non-positive ``H``.
        SolverError: ``hard_tasks`` and the stacked tasks are rank-deficient (conflicting or
            singular).
    """
    options = _options(options)
    robot = state.robot
    _require_actuated(robot, "operational_space_control")
    tasks = list(tasks)
    if not tasks:
        raise InvalidInputError("operational_space_control needs at least one task")
    for task in tasks:
        if task.feature.robot is not robot:
            raise InvalidInputError(
                f"task '{task.name}' is defined on robot '{task.feature.robot.name}', the state on "
                f"'{robot.name}'"
            )
    if not state.has_velocity:
        raise InvalidInputError(
            "operational_space_control needs the velocity: create the state with "
            "robot.state(q, v) (the drift Jdot v of each task)"
        )
    t0 = time.perf_counter()
    nv = robot.nv
    h = _torque_weight(options, nv)
    q, v = state.q, state.v
    data = robot._model.createData()
    M = np.asarray(pin.crba(robot._model, data, q))
    M = np.triu(M) + np.triu(M, 1).T
    F = np.asarray(pin.nonLinearEffects(robot._model, data, q, v))
    # rows sqrt(C) J and sqrt(C) (y''* - Jdot v), stacked over tasks (slide 5:35)
    stack = TaskRowStack(tasks, nv)
    A, b = stack.acceleration(state)
    sizes = [rows.stop - rows.start for rows in stack.slices]
    chol = sla.cho_factor(M)
    T = sla.cho_solve(chol, A.T).T  # sqrt(C) J M^-1
    rhs = b + T @ F
    if options.hard_tasks:
        Hinv_Tt = T.T / h[:, None]
        G = T @ Hinv_Tt
        rank = int(np.linalg.matrix_rank(G))
        if rank < G.shape[0]:
            raise SolverError(
                f"hard_tasks: T H^-1 T^T is singular (rank {rank} < {G.shape[0]} task rows); "
                "the tasks conflict or a Jacobian is singular: use weighted tasks "
                "(hard_tasks=False)"
            )
        tau = Hinv_Tt @ np.linalg.solve(G, rhs)
    else:
        tau = np.linalg.solve(T.T @ T + np.diag(h), T.T @ rhs)
    a = sla.cho_solve(chol, tau - F)
    errors: dict[str, float] = {}
    residual = A @ a - b  # sqrt(C)-weighted: J a - (y''* - Jdot v)
    start = 0
    for task, size in zip(tasks, sizes):
        w = task.sqrt_weight
        block = residual[start : start + size]
        if isinstance(w, float):
            block = block / w if w > 0 else np.full(size, np.nan)
        else:
            block = np.divide(block, w, out=np.full(size, np.nan), where=w > 0)
        errors[task.name] = float(np.linalg.norm(block))
        start += size
    return OperationalSpaceResult(
        success=True,
        status=OperationalSpaceStatus.SOLVED,
        tau=tau,
        a=a,
        task_acceleration_errors=errors,
        solve_time=time.perf_counter() - t0,
    )


class OperationalSpaceController:
    """``controller(t, q, v)`` wrapper of :func:`operational_space_control` for simulation.

    Keeps one :class:`~taskspace.model.state.State`, updated at every call; calls from
    several threads run one at a time (a lock), each with the result it would get alone.

    Args:
        robot: a fixed-base robot.
        tasks: the stacked tasks (targets set).
        options: see :class:`OperationalSpaceOptions`.
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Sequence[Task],
        options: OperationalSpaceOptions | None = None,
    ) -> None:
        _require_actuated(robot, "OperationalSpaceController")
        self.robot = robot
        self.tasks = list(tasks)
        self.options = _options(options)
        self.state = robot.state(robot.q_default, np.zeros(robot.nv))
        self.last_result: OperationalSpaceResult | None = None
        self._lock = threading.Lock()

    def __call__(self, t: float, q: Any, v: Any) -> FloatArray:
        """Torques [N m] at time ``t`` [s]."""
        with self._lock:
            self.state.update(q, v)
            result = operational_space_control(self.state, self.tasks, self.options)
            self.last_result = result
            return result.tau
