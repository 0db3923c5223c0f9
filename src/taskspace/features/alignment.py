"""Alignment of an attached vector with a world reference (slide 2:50).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray
from taskspace.features import _point
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Alignment(Feature):
    """``phi(q) = v*^T R_i(q) v``: 1 aligned, -1 anti-aligned, 0 orthogonal.

    Jacobian ``v*^T J_vec(i, v)``. Both vectors are normalized to unit length (the value is
    the cosine of the angle between them, as the notes read it; with ``[0, 0, 2]`` and a
    target of 1 it was the cosine times 2, reached at 60 degrees).

    Args:
        robot: the robot.
        frame: link i.
        vector: attached vector ``v`` in i's coordinates (non-zero; normalized).
        reference: world reference vector ``v*`` (non-zero; normalized).
    """

    dim = 1

    def __init__(self, robot: Robot, frame: str, vector: Any, reference: Any) -> None:
        super().__init__(robot, f"alignment({frame})")
        self.frame_id = robot.frame_id(frame)
        self.vector = _point.unit_vector(vector, "vector")
        self.reference = _point.unit_vector(reference, "reference")

    def value(self, state: State) -> FloatArray:
        """Scalar product, shape (1,)."""
        self._check_state(state)
        return np.array([self.reference @ _point.vector_value(state, self.frame_id, self.vector)])

    def jacobian(self, state: State) -> FloatArray:
        """1 x nv Jacobian."""
        self._check_state(state)
        return (self.reference @ _point.vector_jacobian(state, self.frame_id, self.vector))[None]

    def drift(self, state: State) -> FloatArray:
        """Second derivative at zero joint acceleration, shape (1,)."""
        self._check_state(state)
        return np.array([self.reference @ _point.vector_drift(state, self.frame_id, self.vector)])
