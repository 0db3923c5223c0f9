"""Vector attached to a link (slide 2:47).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from taskspace._validation import FloatArray
from taskspace.features import _point
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Vector(Feature):
    """World coordinates of a vector attached to a link: ``phi(q) = R_W,i(q) v``.

    Jacobian: ``A_i x phi(q)`` (slide 2:47), i.e. column k is ``omega_k x phi``.

    Args:
        robot: the robot.
        frame: name of the frame the vector is attached to.
        vector: the vector in frame coordinates.
    """

    dim = 3

    def __init__(self, robot: Robot, frame: str, vector: Any) -> None:
        super().__init__(robot, f"vector({frame})")
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.vector = _point.nonzero_vector(vector, "vector")

    def value(self, state: State) -> FloatArray:
        """The vector in world coordinates."""
        self._check_state(state)
        return _point.vector_value(state, self.frame_id, self.vector)

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv Jacobian."""
        self._check_state(state)
        return _point.vector_jacobian(state, self.frame_id, self.vector)

    def drift(self, state: State) -> FloatArray:
        """Second derivative at zero joint acceleration."""
        self._check_state(state)
        return _point.vector_drift(state, self.frame_id, self.vector)
