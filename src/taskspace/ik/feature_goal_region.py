"""A goal region for planners: any vector feature within bounds, sampled by IK.

It satisfies the planners' ``GoalRegion`` protocol (``contains``, ``sample``;
:mod:`taskspace.planning.rrt_star`): a configuration is a goal when the feature's value lies
in ``[lower, upper]`` (e.g. the hand's position in a box, the centre of mass over an area,
a joint in a range), and goal configurations are drawn by :func:`solve_ik` from random
starts toward a random target inside the bounds. For a frame pose within tolerances use
:class:`~taskspace.ik.PoseGoalRegion`.

Thread safety: :meth:`FeatureGoalRegion.sample` sets the target of the region's own IK task,
so one region must not be sampled from two threads at once (give each thread its own region);
:meth:`~FeatureGoalRegion.contains` only reads the robot model and may be called from any
thread.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_vector, check_count
from taskspace.errors import InvalidInputError
from taskspace.features.feature import Feature, require_vector_feature
from taskspace.ik.solve_ik import SolveIKOptions, solve_ik
from taskspace.tasks import Task

FloatArray = npt.NDArray[np.float64]


class FeatureGoalRegion:
    """The configurations at which ``feature``'s value lies within ``[lower, upper]``.

    Args:
        feature: a feature whose value is a vector of size ``feature.dim`` (not a pose or
            an orientation: use :class:`~taskspace.ik.PoseGoalRegion` for those).
        lower, upper: bounds, size ``feature.dim`` (or scalars for every coordinate),
            ``lower < upper``; ``-inf`` / ``inf`` leave a side open. Units: the feature's
            [m, rad, ...]. An equality (``lower == upper``) is refused: the IK reaches a
            value only within its tolerance; give a band around it, a goal configuration,
            or a :class:`~taskspace.ik.PoseGoalRegion` for a frame pose.
        attempts: IK attempts per :meth:`sample` before it gives up (returns ``None``).
        margin: IK targets lie at least this far inside each finite bound (a target on the
            boundary would be missed by the IK's own tolerance) [the feature's units].

    Sampling: each attempt draws ``q0`` uniformly within the joint limits, aims every
    coordinate with two finite bounds at a uniform point of ``[lower + margin, upper -
    margin]`` and every half-open one at its value at ``q0`` clipped inside the bounds, and
    solves the IK from ``q0``; the result is returned only when :meth:`contains` holds.
    """

    def __init__(
        self,
        feature: Feature,
        lower: Any,
        upper: Any,
        *,
        attempts: int = 5,
        margin: float = 1e-4,
    ) -> None:
        if not isinstance(feature, Feature):
            raise InvalidInputError(
                f"feature must be a taskspace Feature, got {type(feature).__name__}"
            )
        robot = feature.robot
        require_vector_feature(
            feature,
            "FeatureGoalRegion",
            "for a frame pose use taskspace.ik.PoseGoalRegion, for a configuration a goal "
            "configuration",
        )
        dim = feature.dim
        lo = np.full(dim, float(lower)) if np.ndim(lower) == 0 else np.asarray(lower, float)
        hi = np.full(dim, float(upper)) if np.ndim(upper) == 0 else np.asarray(upper, float)
        if lo.shape != (dim,) or hi.shape != (dim,):
            raise InvalidInputError(
                f"lower and upper must have size {dim} (the feature's dim), got "
                f"{lo.shape} and {hi.shape}"
            )
        if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
            raise InvalidInputError(f"bounds must be numbers with lower <= upper: {lo}, {hi}")
        if np.any(np.isposinf(lo)) or np.any(np.isneginf(hi)):
            raise InvalidInputError("lower cannot be +inf and upper cannot be -inf")
        equal = np.flatnonzero(lo == hi)
        if equal.size:
            raise InvalidInputError(
                f"lower == upper for coordinate(s) {equal.tolist()} (values "
                f"{lo[equal].tolist()}): a region of zero width, which the IK reaches only "
                "within its tolerance, so no sample of it would be contained (every planner "
                "would spend its budget); give a band around the value (e.g. lower = v - 1e-3, "
                "upper = v + 1e-3), a goal configuration (solve_ik to the value), or "
                "taskspace.ik.PoseGoalRegion for a frame pose"
            )
        margin = float(as_vector([margin], 1, "margin")[0])
        if margin < 0:
            raise InvalidInputError(f"margin must be >= 0, got {margin}")
        self.feature = feature
        self.robot = robot
        self.lower, self.upper = lo, hi
        self.attempts = check_count(attempts, "attempts", minimum=1)
        self.margin = margin
        self._task = Task(feature)

    def value(self, q: FloatArray) -> FloatArray:
        """The feature's value at ``q``."""
        return np.asarray(self.feature.value(self.robot.state(q)), dtype=np.float64)

    def contains(self, q: FloatArray) -> bool:
        """Whether the feature's value at ``q`` lies within ``[lower, upper]``."""
        y = self.value(q)
        return bool(np.all(y >= self.lower) and np.all(y <= self.upper))

    def sample(self, rng: np.random.Generator) -> FloatArray | None:
        """A goal configuration within the joint limits, or ``None`` after ``attempts``."""
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
                f"{type(rng).__name__}"
            )
        lo, hi = self.lower, self.upper
        finite = np.isfinite(lo) & np.isfinite(hi)
        width = np.where(finite, hi - lo, 0.0)
        inset = np.where(finite, np.minimum(self.margin, width / 2), self.margin)
        inner_lo, inner_hi = lo + inset, hi - inset  # infinite bounds stay infinite
        for _ in range(self.attempts):
            q0 = self.robot.random_configuration(rng)
            target = np.clip(self.value(q0), inner_lo, inner_hi)
            u = rng.random(lo.size)
            target[finite] = inner_lo[finite] + u[finite] * (inner_hi - inner_lo)[finite]
            self._task.set_target(target)
            result = solve_ik(self.robot, [self._task], q0=q0, options=SolveIKOptions(restarts=0))
            if result.success and self.contains(result.q):
                return np.asarray(result.q, dtype=np.float64)
        return None
