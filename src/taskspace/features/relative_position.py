"""Position of a point on link i relative to a point on link j (slide 2:48).

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

from taskspace._validation import FloatArray, as_vector
from taskspace.features import _point
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


def relative_jacobian(
    R_j: FloatArray, d: FloatArray, J_d: FloatArray, J_ang_j: FloatArray
) -> FloatArray:
    """Jacobian of ``y = R_j^T d``: ``R_j^T (J_d - A_j x d)`` (slide 2:48)."""
    return np.asarray(R_j.T @ (J_d - _point.cross_columns(J_ang_j, d)))


def relative_drift(
    R_j: FloatArray,
    d: FloatArray,
    d_dot: FloatArray,
    d_ddot: FloatArray,
    omega_j: FloatArray,
    alpha_j: FloatArray,
) -> FloatArray:
    """Drift of ``y = R_j^T d``.

    ``R_j^T (d'' - alpha x d - 2 omega x d' + omega x (omega x d))``.
    """
    return np.asarray(
        R_j.T
        @ (
            d_ddot
            - np.cross(alpha_j, d)
            - 2.0 * np.cross(omega_j, d_dot)
            + np.cross(omega_j, np.cross(omega_j, d))
        )
    )


class RelativePosition(Feature):
    """``phi(q) = R_j^-1 (phi_pos(i, v) - phi_pos(j, w))``: point of link i in frame j [m].

    Args:
        robot: the robot.
        frame: link i.
        reference_frame: link j.
        offset: point on i in i's coordinates [m] (``v``; default origin).
        reference_offset: point on j in j's coordinates [m] (``w``; default origin).
    """

    dim = 3

    def __init__(
        self,
        robot: Robot,
        frame: str,
        reference_frame: str,
        offset: Any = None,
        reference_offset: Any = None,
    ) -> None:
        super().__init__(robot, f"relative_position({frame}|{reference_frame})")
        self.frame_id = robot.frame_id(frame)
        self.reference_id = robot.frame_id(reference_frame)
        self.offset = None if offset is None else as_vector(offset, 3, "offset")
        self.reference_offset = (
            None if reference_offset is None else as_vector(reference_offset, 3, "reference_offset")
        )

    def _d(self, state: State) -> FloatArray:
        return _point.point_position(state, self.frame_id, self.offset) - _point.point_position(
            state, self.reference_id, self.reference_offset
        )

    def value(self, state: State) -> FloatArray:
        """Coordinates of point i in frame j [m]."""
        self._check_state(state)
        R_j = state.frame_placement(self.reference_id).rotation
        return np.asarray(R_j.T @ self._d(state))

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv Jacobian."""
        self._check_state(state)
        J_d = _point.point_jacobian(state, self.frame_id, self.offset) - _point.point_jacobian(
            state, self.reference_id, self.reference_offset
        )
        R_j = state.frame_placement(self.reference_id).rotation
        return relative_jacobian(
            R_j, self._d(state), J_d, state.frame_jacobian(self.reference_id)[3:]
        )

    def drift(self, state: State) -> FloatArray:
        """Acceleration of the relative coordinates at zero joint acceleration."""
        self._check_state(state)
        i, j = self.frame_id, self.reference_id
        d_dot = _point.point_velocity(state, i, self.offset) - _point.point_velocity(
            state, j, self.reference_offset
        )
        d_ddot = _point.point_drift(state, i, self.offset) - _point.point_drift(
            state, j, self.reference_offset
        )
        return relative_drift(
            state.frame_placement(j).rotation,
            self._d(state),
            d_dot,
            d_ddot,
            state.frame_velocity(j)[3:],
            state.frame_drift(j)[3:],
        )
