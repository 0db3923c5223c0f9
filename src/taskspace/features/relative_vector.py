"""Vector attached to link i expressed in link j (slide 2:49).

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
from taskspace.features.relative_position import relative_drift, relative_jacobian

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class RelativeVector(Feature):
    """``phi(q) = R_j^-1 R_i v``; Jacobian ``R_j^-1 (J_vec(i, v) - A_j x phi_vec(i, v))``.

    Args:
        robot: the robot.
        frame: link i carrying the vector.
        reference_frame: link j.
        vector: the vector in i's coordinates.
    """

    dim = 3

    def __init__(self, robot: Robot, frame: str, reference_frame: str, vector: Any) -> None:
        super().__init__(robot, f"relative_vector({frame}|{reference_frame})")
        self.frame_id = robot.frame_id(frame)
        self.reference_id = robot.frame_id(reference_frame)
        self.vector = _point.nonzero_vector(vector, "vector")

    def value(self, state: State) -> FloatArray:
        """The vector in frame j coordinates."""
        self._check_state(state)
        R_j = state.frame_placement(self.reference_id).rotation
        return np.asarray(R_j.T @ _point.vector_value(state, self.frame_id, self.vector))

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv Jacobian."""
        self._check_state(state)
        u = _point.vector_value(state, self.frame_id, self.vector)
        J_u = _point.vector_jacobian(state, self.frame_id, self.vector)
        R_j = state.frame_placement(self.reference_id).rotation
        return relative_jacobian(R_j, u, J_u, state.frame_jacobian(self.reference_id)[3:])

    def drift(self, state: State) -> FloatArray:
        """Second derivative at zero joint acceleration."""
        self._check_state(state)
        i, j = self.frame_id, self.reference_id
        return relative_drift(
            state.frame_placement(j).rotation,
            _point.vector_value(state, i, self.vector),
            _point.vector_velocity(state, i, self.vector),
            _point.vector_drift(state, i, self.vector),
            state.frame_velocity(j)[3:],
            state.frame_drift(j)[3:],
        )
