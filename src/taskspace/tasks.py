"""A ``Task`` binds a feature to a target, a precision (weight), a gain and a priority level."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray, as_vector, check_positive
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.features.feature import Feature
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
            stack; the relative weight inside a priority level in a hierarchy.
        gain: fraction of the error corrected per step, in (0, 1].
        priority: level in a strict hierarchy (0 = highest). Ignored by weighted solvers.
        kp: stiffness of the acceleration-level reference (inverse dynamics, operational
            space control): ``y''* = y''_ref - kp e - kd (e' - y'_ref)`` [1/s^2].
        kd: damping [1/s]; default ``2 sqrt(kp)`` (critical damping).
        name: label (default: the feature's name).
    """

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
        name: str | None = None,
    ) -> None:
        self.feature = feature
        self.name = name or feature.name
        self._target: Any = None
        if target is not None:
            self.set_target(target)
        w = np.asarray(weight, dtype=float)
        if w.ndim == 0:
            check_positive(float(w), f"weight of task '{self.name}'", strict=False)
            self.sqrt_weight: float | FloatArray = float(np.sqrt(w))
        else:
            w = as_vector(w, feature.dim, f"weight of task '{self.name}'")
            if np.any(w < 0):
                raise InvalidInputError(f"weight of task '{self.name}' must be >= 0")
            self.sqrt_weight = np.sqrt(w)
        g = float(gain)
        if not 0.0 < g <= 1.0:
            raise InvalidInputError(f"gain of task '{self.name}' must be in (0, 1], got {gain}")
        self.gain = g
        if int(priority) < 0:
            raise InvalidInputError(f"priority of task '{self.name}' must be >= 0")
        self.priority = int(priority)
        self.kp = check_positive(kp, f"kp of task '{self.name}'", strict=False)
        self.kd = (
            2.0 * float(np.sqrt(self.kp))
            if kd is None
            else check_positive(kd, f"kd of task '{self.name}'", strict=False)
        )
        self.reference_velocity: FloatArray | None = None
        self.reference_acceleration: FloatArray | None = None

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
        self._target = self.feature.check_target(target)

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

    def rows(self, state: State) -> tuple[FloatArray, FloatArray]:
        """Weighted rows ``(sqrt(rho) J, -sqrt(rho) gain e)`` of ``J dq ~ -gain e``."""
        e, J = self.feature.residual_and_jacobian(state, self._require_target())
        w = self.sqrt_weight
        if isinstance(w, float):
            return (J if w == 1.0 else w * J), (-self.gain * w) * e
        return w[:, None] * J, (-self.gain * w) * e

    def set_reference(self, velocity: Any = None, acceleration: Any = None) -> None:
        """Feed-forward velocity and acceleration of the target (tangent, size dim)."""
        d = self.feature.dim
        self.reference_velocity = (
            None if velocity is None else as_vector(velocity, d, "reference velocity")
        )
        self.reference_acceleration = (
            None if acceleration is None else as_vector(acceleration, d, "reference acceleration")
        )

    def acceleration_rows(self, state: State) -> tuple[FloatArray, FloatArray]:
        """Weighted rows ``(sqrt(rho) J, sqrt(rho)(y''* - Jdot v))`` of ``J a ~ y''* - Jdot v``.

        ``y''* = y''_ref - kp e - kd (J v - y'_ref)`` (slide 5:28 in task space; slide 5:34).
        The state must carry the velocity (drift terms).
        """
        e, J = self.feature.residual_and_jacobian(state, self._require_target())
        e_dot = J @ state.v
        if self.reference_velocity is not None:
            e_dot = e_dot - self.reference_velocity
        desired = -self.kp * e - self.kd * e_dot
        if self.reference_acceleration is not None:
            desired = desired + self.reference_acceleration
        rhs = desired - self.feature.drift(state)
        w = self.sqrt_weight
        if isinstance(w, float) and w == 1.0:
            return J, rhs
        return w * J if isinstance(w, float) else w[:, None] * J, w * rhs

    def __repr__(self) -> str:
        return f"Task('{self.name}', priority={self.priority}, gain={self.gain})"
