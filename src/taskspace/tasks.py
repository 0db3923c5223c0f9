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
        return w * J if not isinstance(w, float) or w != 1.0 else J, (-self.gain * w) * e

    def __repr__(self) -> str:
        return f"Task('{self.name}', priority={self.priority}, gain={self.gain})"
