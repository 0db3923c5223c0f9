"""Orientation of a frame, with the SO(3) logarithm as error.

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
import pinocchio as pin

from taskspace._validation import FloatArray, as_matrix
from taskspace.errors import InvalidInputError
from taskspace.features.compiled import CompiledTerm
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Orientation(Feature):
    """Rotation ``R_W,i(q)`` of a frame; residual ``log3(R*^T R(q))`` [rad] (body frame).

    Jacobian: the angular rows of the LOCAL frame Jacobian; residual Jacobian
    ``Jlog3(R*^T R) J_ang``.

    Args:
        robot: the robot.
        frame: frame name.
    """

    dim = 3

    def __init__(self, robot: Robot, frame: str) -> None:
        super().__init__(robot, f"orientation({frame})")
        self.frame = frame
        self.frame_id = robot.frame_id(frame)

    def check_target(self, target: Any) -> FloatArray:
        """A 3x3 rotation matrix."""
        R = as_matrix(target, (3, 3), f"target of feature '{self.name}'")
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InvalidInputError(f"target of feature '{self.name}' is not a rotation matrix")
        return R

    def value(self, state: State) -> FloatArray:
        """Rotation matrix (copy)."""
        self._check_state(state)
        return np.array(state.frame_placement(self.frame_id).rotation)

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv angular LOCAL Jacobian."""
        self._check_state(state)
        return state.frame_jacobian_local(self.frame_id)[3:]

    def compiled_term(self) -> CompiledTerm:
        """The inverse-dynamics kernel evaluates the rotation error and its LOCAL Jacobian."""
        return CompiledTerm("orientation", self.frame_id)

    def drift(self, state: State) -> FloatArray:
        """Body angular acceleration at zero joint acceleration [rad/s^2]."""
        self._check_state(state)
        return state.frame_drift_local(self.frame_id)[3:]

    def residual(self, state: State, target: Any) -> FloatArray:
        """``log3(R*^T R)`` [rad]."""
        self._check_state(state)
        return np.asarray(pin.log3(target.T @ state.frame_placement(self.frame_id).rotation))

    def residual_jacobian(self, state: State, target: Any) -> FloatArray:
        """``Jlog3(R*^T R) J_ang``."""
        self._check_state(state)
        error = target.T @ state.frame_placement(self.frame_id).rotation
        return np.asarray(pin.Jlog3(error) @ state.frame_jacobian_local(self.frame_id)[3:])
