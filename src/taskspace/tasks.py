"""A ``Task`` binds a feature to a target, a precision (weight), a gain and a priority level.

Thread safety: a task holds its target, reference, weight and gains, which its setters replace
one attribute at a time, without a lock; building its rows reads them and the
:class:`~taskspace.model.State` given. Solvers in several threads may share a task that nobody
changes meanwhile; a task changed by one thread while another steps with it may be read partly
changed (a new target with the old reference velocity). Change a task from the thread that
steps with it, or between steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    as_vector,
    check_int,
    check_positive,
)
from taskspace.errors import InvalidInputError
from taskspace.features.feature import Feature
from taskspace.features.rows import FeatureRows, TaskRows

if TYPE_CHECKING:
    from taskspace.model.state import State


class Task:
    """Drive ``feature`` toward ``target``: the term ``rho |phi(q) - y*|^2`` of slide 2:39.

    In a differential (velocity-level) step ``dq`` the linearized task reads
    ``e + J dq = (1 - gain) e``: the step removes the fraction ``gain`` of the error ``e``.

    Args:
        feature: the task variable.
        target: desired value (see the feature's ``check_target``); may be set later with
            :meth:`set_target`.
        weight: precision ``rho`` (scalar, or one value per feature dimension) in a weighted
            stack; the relative weight inside a priority level in a hierarchy. Finite, in
            ``[0, 1e20]`` (:data:`MAX_WEIGHT`; it enters the QP's Hessian as
            ``rho J^T J``: beyond 1e20 a weight-1 task is below double precision next to
            it, and beyond 1e30 the QP refuses the Hessian; for strict precedence use
            priority levels).
        gain: fraction of the error corrected per step, in (0, 1].
        priority: level in a strict hierarchy (0 = highest). Ignored by weighted solvers.
        kp: stiffness of the acceleration-level reference (inverse dynamics, operational
            space control): ``y''* = y''_ref - kp e - kd (e' - y'_ref)`` [1/s^2].
        kd: damping [1/s]; default ``2 sqrt(kp)`` (critical damping).
        lm_damping: Levenberg-Marquardt damping ``lambda`` of this task at the velocity
            level: the step's regularization grows with the task's weighted error, ``H +=
            lambda |sqrt(rho) e|^2 I`` (pink's ``lm_damping``), so steps shrink far from the
            target and the solution stays exact at it; in :class:`~taskspace.ik.DifferentialIK`
            it adds to the whole step's damping, in :class:`~taskspace.ik.HierarchicalIK` to
            the damping of the task's level. Not used at the acceleration level. Finite,
            ``>= 0`` (default 0: off).
        name: label (default: the feature's name).
    """

    # Plain attributes (read on every step without a property call), validated on assignment
    # by __setattr__: assigning an invalid value raises and leaves the task unchanged.
    sqrt_weight: float | FloatArray
    gain: float
    priority: int
    kp: float
    kd: float
    lm_damping: float

    def __init__(
        self,
        feature: Feature,
        target: Any = None,
        *,
        weight: float | FloatArray = 1.0,
        gain: float = 1.0,
        priority: int = 0,
        kp: float = 100.0,
        kd: float | None = None,
        lm_damping: float = 0.0,
        name: str | None = None,
    ) -> None:
        if not isinstance(feature, Feature):
            raise InvalidInputError(
                f"Task needs a feature (taskspace.features: Position, FramePose, ...), got "
                f"{type(feature).__name__}"
            )
        if name is not None and not isinstance(name, str):
            raise InvalidInputError(f"task name must be a string, got {type(name).__name__}")
        self.feature = feature
        self.name = name or feature.name
        self._target: Any = None
        if target is not None:
            self.set_target(target)
        elif (default := getattr(feature, "default_target", None)) is not None:
            self.set_target(default())  # a feature with one possible target (Damping)
        self.weight = weight
        self.gain = gain
        self.priority = priority
        self.kp = kp
        self.kd = 2.0 * math.sqrt(self.kp) if kd is None else kd
        self.lm_damping = lm_damping
        self.reference_velocity: FloatArray | None = None
        self.reference_acceleration: FloatArray | None = None

    def __setattr__(self, name: str, value: Any) -> None:
        check = _SETTERS.get(name)
        if check is not None:
            value = check(self, value)
            ASSIGNMENTS[0] += 1  # after the check: a refused value leaves everything as it was
        object.__setattr__(self, name, value)

    @property
    def weight(self) -> float | FloatArray:
        """Precision ``rho = sqrt_weight^2`` (scalar or one value per dimension).

        Assigning it validates the value (finite, ``>= 0``, scalar or of size ``dim``) and
        sets :attr:`sqrt_weight`.
        """
        w = self.sqrt_weight
        return w * w if isinstance(w, float) else np.square(w)

    @weight.setter
    def weight(self, value: Any) -> None:
        self.sqrt_weight = _sqrt_of_weight(self, value)

    @property
    def dim(self) -> int:
        """Number of rows the task contributes."""
        return self.feature.dim

    @property
    def target(self) -> Any:
        """Current target."""
        return self._target

    def set_target(self, target: Any) -> None:
        """Validate and set the target."""
        object.__setattr__(self, "_target", self.feature.check_target(target))

    def set_target_from_state(self, state: State) -> None:
        """Set the target to the feature's current value (hold the current value)."""
        value = self.feature.value(state)
        if hasattr(value, "copy"):
            value = value.copy()
        self.set_target(value)

    def error(self, state: State) -> FloatArray:
        """Residual ``e = phi(q) (-) y*``."""
        return self.feature.residual(state, self._require_target())

    def _require_target(self) -> Any:
        if self._target is None:
            raise InvalidInputError(
                f"task '{self.name}' has no target: call task.set_target(...) or "
                "task.set_target_from_state(state)"
            )
        return self._target

    def rows(self, state: State) -> TaskRows:
        """Weighted rows ``(sqrt(rho) J, -sqrt(rho) gain e)`` of ``J dq ~ -gain e``."""
        e, J = self.feature.residual_and_jacobian(state, self._require_target())
        w = self.sqrt_weight
        if isinstance(w, float):
            return TaskRows((J if w == 1.0 else w * J), (-self.gain * w) * e)
        return TaskRows(w[:, None] * J, (-self.gain * w) * e)

    def feature_rows(self, state: State, drift: bool = False) -> FeatureRows:
        """The feature's residual, its Jacobian, (``drift``) ``Jdot v`` and ``sqrt(rho)``.

        The raw values from which the stacking layer (:mod:`taskspace.qp.rows`) forms the
        rows of many tasks at once; ``drift`` needs a state made with the velocity.
        """
        e, J = self.feature.residual_and_jacobian(state, self._require_target())
        return FeatureRows(J, e, self.feature.drift(state) if drift else None, self.sqrt_weight)

    def set_reference(self, velocity: Any = None, acceleration: Any = None) -> None:
        """Feed-forward velocity and acceleration of the target (tangent, size dim)."""
        self.reference_velocity = velocity  # validated by __setattr__ (_SETTERS)
        self.reference_acceleration = acceleration

    def acceleration_rows(self, state: State) -> TaskRows:
        """Weighted rows ``(sqrt(rho) J, sqrt(rho)(y''* - Jdot v))`` of ``J a ~ y''* - Jdot v``.

        ``y''* = y''_ref - kp e - kd (J v - y'_ref)`` (slide 5:28 in task space; slide 5:34).
        The state must carry the velocity (drift terms). Controllers stack many tasks with
        :class:`taskspace.qp.rows.TaskRowStack`, which computes the same rows in place.
        """
        e, J = self.feature.residual_and_jacobian(state, self._require_target())
        # rhs = -(kp e + kd (J v - y'_ref) + Jdot v - y''_ref)
        rhs = self.kd * J.dot(state.v)
        if self.reference_velocity is not None:
            rhs -= self.kd * self.reference_velocity
        rhs += self.kp * e
        rhs += self.feature.drift(state)
        if self.reference_acceleration is not None:
            rhs -= self.reference_acceleration
        w = self.sqrt_weight
        if isinstance(w, float):
            return TaskRows(w * J, -w * rhs)
        return TaskRows(w[:, None] * J, -w * rhs)

    def __repr__(self) -> str:
        return f"Task('{self.name}', priority={self.priority}, gain={self.gain})"


def _label(task: Task) -> str:
    return getattr(task, "name", "?")


MAX_WEIGHT = 1e20
"""Largest accepted task weight ``rho``. It enters the QP's Hessian as ``rho J^T J``: next to
a weight of 1e20 a weight-1 task (and the solvers' regularization, 1e-6 and below) is lost in
double precision (1e-16 relative), and from 1e30 on the QP's magnitude check
(:data:`taskspace.qp.solver.MAX_QP_MAGNITUDE`) refuses the Hessian without naming the task."""
_MAX_SQRT_WEIGHT = 1e10


def _bounded(task: Task, w: Any, name: str, limit: float) -> None:
    if np.any(np.asarray(w) > limit):
        raise InvalidInputError(
            f"{name} must be <= {limit:g}, got {w}: beyond it the other tasks are lost in "
            "double precision next to this one (and from 1e30 on the QP refuses its Hessian); "
            "use priority levels (HierarchicalIK) for strict precedence"
        )


def _sqrt_of_weight(task: Task, value: Any) -> float | FloatArray:
    """``sqrt(weight)`` of a validated weight (finite, >= 0, scalar or of size dim)."""
    name = f"weight of task '{_label(task)}'"
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        v = check_positive(value, name, strict=False)
        _bounded(task, v, name, MAX_WEIGHT)
        return math.sqrt(v)
    w = as_float_array(value, name)
    if w.ndim == 0:
        v = check_positive(float(w), name, strict=False)
        _bounded(task, v, name, MAX_WEIGHT)
        return math.sqrt(v)
    w = as_vector(w, task.feature.dim, name)
    if np.any(w < 0):
        raise InvalidInputError(f"{name} must be >= 0")
    _bounded(task, w, name, MAX_WEIGHT)
    return np.sqrt(w)


def _check_sqrt_weight(task: Task, value: Any) -> float | FloatArray:
    name = f"sqrt_weight of task '{_label(task)}'"
    if value.__class__ is float and 0.0 <= value <= _MAX_SQRT_WEIGHT:
        return value  # fast path; keeps the identity of the object (stacks compare it)
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        v = check_positive(value, name, strict=False)
        _bounded(task, v, name, _MAX_SQRT_WEIGHT)
        return v
    w = as_float_array(value, name)
    if w.ndim == 0:
        v = check_positive(float(w), name, strict=False)
        _bounded(task, v, name, _MAX_SQRT_WEIGHT)
        return v
    w = as_vector(w, task.feature.dim, name)
    if np.any(w < 0):
        raise InvalidInputError(f"{name} must be >= 0")
    _bounded(task, w, name, _MAX_SQRT_WEIGHT)
    w = w.copy() if w is value else w
    w.setflags(write=False)  # an in-place change would bypass this check and the stacks
    return w


def _check_gain(task: Task, value: Any) -> float:
    if value.__class__ is float and 0.0 < value <= 1.0:
        return value  # fast path (solve_ik and interpolation save and restore gains)
    g = as_scalar(value, f"gain of task '{_label(task)}'")
    if not 0.0 < g <= 1.0:
        raise InvalidInputError(f"gain of task '{_label(task)}' must be in (0, 1], got {value!r}")
    return g


def _check_priority(task: Task, value: Any) -> int:
    p = check_int(value, f"priority of task '{_label(task)}'")
    if p < 0:
        raise InvalidInputError(f"priority of task '{_label(task)}' must be >= 0")
    return p


def _check_kp(task: Task, value: Any) -> float:
    return check_positive(value, f"kp of task '{_label(task)}'", strict=False)


def _check_kd(task: Task, value: Any) -> float:
    return check_positive(value, f"kd of task '{_label(task)}'", strict=False)


def _check_lm_damping(task: Task, value: Any) -> float:
    return check_positive(value, f"lm_damping of task '{_label(task)}'", strict=False)


def _check_reference_velocity(task: Task, value: Any) -> FloatArray | None:
    if value is None:
        return None
    return as_vector(value, task.feature.dim, f"reference velocity of task '{_label(task)}'")


def _check_reference_acceleration(task: Task, value: Any) -> FloatArray | None:
    if value is None:
        return None
    return as_vector(value, task.feature.dim, f"reference acceleration of task '{_label(task)}'")


def _check_target(task: Task, value: Any) -> Any:
    # ``task._target = x`` (private, but reachable): the kernels extract it as the feature's
    # target type (a bare Boost TypeError otherwise), so it is validated like set_target's
    if value is None or "feature" not in task.__dict__:
        return value
    return task.feature.check_target(value)


def _check_feature(task: Task, value: Any) -> Any:
    if "feature" in task.__dict__:
        # solvers and compiled kernels derive rows (sizes, frames) from it at construction
        raise InvalidInputError(
            f"task '{_label(task)}': its feature is fixed at construction (solvers, "
            f"controllers and compiled kernels are built from it): make a new Task"
        )
    return value


ASSIGNMENTS = [0]
"""How many checked attributes (weights, gains, damping, ...) of any task were assigned so
far (one counter for all tasks, in a list so that readers see it change). A solver that
keeps a copy of its tasks' weights (the compiled IK kernel) re-reads them only when it has
changed: one comparison per step instead of one per task."""

_SETTERS: dict[str, Callable[[Task, Any], Any]] = {
    "_target": _check_target,
    "feature": _check_feature,
    "reference_velocity": _check_reference_velocity,
    "reference_acceleration": _check_reference_acceleration,
    "lm_damping": _check_lm_damping,
    "sqrt_weight": _check_sqrt_weight,
    "gain": _check_gain,
    "priority": _check_priority,
    "kp": _check_kp,
    "kd": _check_kd,
}
