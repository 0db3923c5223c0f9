"""Alignment of a vector on link i with a vector on link j (slide 2:51).

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


class RelativeAlignment(Feature):
    """``phi(q) = phi_vec(j, w)^T phi_vec(i, v)``: 1 aligned, -1 anti-aligned, 0 orthogonal.

    Jacobian ``phi_vec(j, w)^T J_vec(i, v) + phi_vec(i, v)^T J_vec(j, w)``. Both vectors are
    normalized to unit length (the value is the cosine of the angle between them).

    Args:
        robot: the robot.
        frame: link i.
        vector: vector ``v`` on i (i's coordinates; non-zero, normalized).
        reference_frame: link j.
        reference_vector: vector ``w`` on j (j's coordinates; non-zero, normalized).
    """

    dim = 1

    def __init__(
        self, robot: Robot, frame: str, vector: Any, reference_frame: str, reference_vector: Any
    ) -> None:
        super().__init__(robot, f"relative_alignment({frame}|{reference_frame})")
        self.frame_id = robot.frame_id(frame)
        self.reference_id = robot.frame_id(reference_frame)
        self.vector = _point.unit_vector(vector, "vector")
        self.reference_vector = _point.unit_vector(reference_vector, "reference_vector")

    def value(self, state: State) -> FloatArray:
        """Scalar product, shape (1,)."""
        self._check_state(state)
        u = _point.vector_value(state, self.frame_id, self.vector)
        w = _point.vector_value(state, self.reference_id, self.reference_vector)
        return np.array([u @ w])

    def jacobian(self, state: State) -> FloatArray:
        """1 x nv Jacobian."""
        self._check_state(state)
        i, j = self.frame_id, self.reference_id
        u = _point.vector_value(state, i, self.vector)
        w = _point.vector_value(state, j, self.reference_vector)
        J_u = _point.vector_jacobian(state, i, self.vector)
        J_w = _point.vector_jacobian(state, j, self.reference_vector)
        return (w @ J_u + u @ J_w)[None]

    def drift(self, state: State) -> FloatArray:
        """Second derivative at zero joint acceleration: ``w.u'' + u.w'' + 2 u'.w'``."""
        self._check_state(state)
        i, j = self.frame_id, self.reference_id
        u = _point.vector_value(state, i, self.vector)
        w = _point.vector_value(state, j, self.reference_vector)
        du = _point.vector_velocity(state, i, self.vector)
        dw = _point.vector_velocity(state, j, self.reference_vector)
        ddu = _point.vector_drift(state, i, self.vector)
        ddw = _point.vector_drift(state, j, self.reference_vector)
        return np.array([w @ ddu + u @ ddw + 2.0 * du @ dw])
