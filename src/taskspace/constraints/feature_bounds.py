"""Bounds on any vector feature, linearized: ``lower <= phi(q) + J dq <= upper``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import as_vector
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError
from taskspace.features.rows import INF, InequalityRows

if TYPE_CHECKING:
    from taskspace.features.feature import Feature
    from taskspace.model.state import State


class FeatureBounds(Constraint):
    """Keep a vector feature within ``[lower, upper]`` (e.g. the CoM over the support area).

    Args:
        feature: a feature whose value is a vector (not a pose).
        lower, upper: bounds (size ``feature.dim``; ``-inf``/``inf`` allowed).
        gain: fraction of a current violation corrected per step, in (0, 1].
        name: label (default from the feature).
    """

    def __init__(
        self,
        feature: Feature,
        lower: Any,
        upper: Any,
        gain: float = 1.0,
        name: str | None = None,
    ) -> None:
        super().__init__(feature.robot, name or f"bounds on {feature.name}")
        self.feature = feature
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        lo = np.where(np.isneginf(lo), -INF, lo) if lo.ndim else np.full(feature.dim, lo)
        hi = np.where(np.isposinf(hi), INF, hi) if hi.ndim else np.full(feature.dim, hi)
        self.lower = as_vector(np.maximum(lo, -INF), feature.dim, "lower")
        self.upper = as_vector(np.minimum(hi, INF), feature.dim, "upper")
        if np.any(self.lower > self.upper):
            raise InvalidInputError(f"{self.name}: lower > upper")
        if not 0.0 < gain <= 1.0:
            raise InvalidInputError(f"gain must be in (0, 1], got {gain}")
        self.gain = float(gain)

    def inequalities(self, state: State, dt: float) -> InequalityRows:
        """``lower - phi <= J dq <= upper - phi`` (violations corrected with ``gain``)."""
        y = np.asarray(self.feature.value(state), dtype=float)
        J = self.feature.jacobian(state)
        lo = self.lower - y
        hi = self.upper - y
        # when already outside, only require the fraction `gain` of the way back
        lo = np.where(lo > 0, self.gain * lo, lo)
        hi = np.where(hi < 0, self.gain * hi, hi)
        return InequalityRows(J, np.maximum(lo, -INF), np.minimum(hi, INF))
