"""Position of a point attached to a link (slide 2:46).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from taskspace._validation import FloatArray, as_vector
from taskspace.features import _point
from taskspace.features.compiled import CompiledTerm
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Position(Feature):
    """World position of a point on a link: ``phi(q) = T_W,i(q) v`` [m].

    Jacobian column k: ``[k < i] a_k x (phi(q) - p_k)`` (slide 2:46), from Pinocchio's frame
    Jacobian.

    Args:
        robot: the robot.
        frame: name of the frame the point is attached to.
        offset: point coordinates in that frame [m] (default: the frame origin).
    """

    dim = 3

    def __init__(self, robot: Robot, frame: str, offset: Any = None) -> None:
        super().__init__(robot, f"position({frame})")
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.offset: FloatArray | None = None if offset is None else as_vector(offset, 3, "offset")

    def value(self, state: State) -> FloatArray:
        """World position [m]."""
        self._check_state(state)
        return _point.point_position(state, self.frame_id, self.offset)

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv position Jacobian."""
        self._check_state(state)
        return _point.point_jacobian(state, self.frame_id, self.offset)

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """``p(q) - p*`` and the position Jacobian."""
        if state.robot is not self.robot:
            self._check_state(state)
        fid, offset = self.frame_id, self.offset
        if offset is None:  # fast path: the frame origin
            return state.frame_placement(fid).translation - target, state.frame_jacobian(fid)[:3]
        return (
            _point.point_position(state, fid, offset) - target,
            _point.point_jacobian(state, fid, offset),
        )

    def compiled_term(self) -> CompiledTerm | None:
        """The kernel evaluates frame origins (no offset)."""
        return CompiledTerm("position", self.frame_id) if self.offset is None else None

    def drift(self, state: State) -> FloatArray:
        """Point acceleration at zero joint acceleration [m/s^2]."""
        self._check_state(state)
        return _point.point_drift(state, self.frame_id, self.offset)
