"""Bounds on any vector feature, linearized: ``lower <= phi(q) + J dq <= upper``.

Thread safety: a constraint keeps no per-step workspace besides immutable caches replaced at
once (e.g. the velocity box for the last ``dt``), and reads the :class:`~taskspace.model.State`
it is given, so one constraint may serve solvers in several threads. What it derives from the
robot (limits, collision pairs, compiled rows) is rebuilt on the next call after a model or
world change; do not change the robot, the world or the constraint's parameters (bounds, gains,
margins) while another thread steps with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import as_vector
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError
from taskspace.features.compiled import CompiledConstraint, compiled_term
from taskspace.features.feature import Feature, require_vector_feature
from taskspace.features.rows import INF, InequalityRows

if TYPE_CHECKING:
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
        if not isinstance(feature, Feature):
            raise InvalidInputError(
                f"FeatureBounds needs a taskspace Feature, got {type(feature).__name__}"
            )
        require_vector_feature(
            feature,
            "FeatureBounds",
            "bound a vector feature instead (Position, Vector, RelativePosition, "
            "CenterOfMass...); for joint ranges use robot.set_limits and JointPositionLimits "
            "(JointConfiguration's value is the whole q: bounded only with every joint and nq == "
            "nv)",
        )
        super().__init__(feature.robot, name or f"bounds on {feature.name}")
        self.feature = feature
        self.upper = upper  # each checked by __setattr__ (also when changed later)
        self.lower = lower
        self.gain = gain

    def __setattr__(self, name: str, value: object) -> None:
        """Check ``lower``, ``upper`` (``lower <= upper``) and ``gain`` on every assignment."""
        if name in ("lower", "upper"):
            arr = np.asarray(value, dtype=float)
            dim = self.feature.dim
            if name == "lower":
                arr = np.where(np.isneginf(arr), -INF, arr) if arr.ndim else np.full(dim, arr)
                value = as_vector(np.maximum(arr, -INF), dim, "lower")
            else:
                arr = np.where(np.isposinf(arr), INF, arr) if arr.ndim else np.full(dim, arr)
                value = as_vector(np.minimum(arr, INF), dim, "upper")
            other = getattr(self, "upper" if name == "lower" else "lower", None)
            if other is not None:
                lo, hi = (value, other) if name == "lower" else (other, value)
                if np.any(lo > hi):
                    raise InvalidInputError(f"{self.name}: lower > upper")
        elif name == "gain":
            ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                value, bool
            )
            if not ok or not 0.0 < value <= 1.0:  # type: ignore[operator]
                raise InvalidInputError(f"gain must be in (0, 1], got {value}")
            value = float(value)  # type: ignore[arg-type]
        super().__setattr__(name, value)

    def compiled_constraint(self) -> CompiledConstraint | None:
        """The bounds as a compiled kernel evaluates them, when the feature declares a term.

        ``None`` when the feature's class declares no compiled term: the rows of
        :meth:`inequalities` are then evaluated in Python (a compiled step may still take
        them as rows). A subclass is served only if it declares this method itself.
        """
        term = compiled_term(self.feature)
        if term is None:
            return None
        return CompiledConstraint(
            "bounds", gain=self.gain, term=term, lower=self.lower, upper=self.upper
        )

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
