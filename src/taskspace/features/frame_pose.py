"""Pose of a frame, with the SE(3) logarithm as error.

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

from taskspace._validation import FloatArray, as_float_array
from taskspace.features.compiled import CompiledTerm
from taskspace.features.feature import Feature
from taskspace.model.world import as_se3

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class FramePose(Feature):
    """Pose ``T_W,i(q)`` of a frame; residual ``log6(T*^-1 T(q))`` (body frame, 6-D).

    The Jacobian is the LOCAL frame Jacobian (body twist ``nu = J v``, rows linear then
    angular); the residual Jacobian is ``Jlog6(T*^-1 T) J``. The residual's first three
    entries are a position error [m], the last three a rotation vector [rad].

    Args:
        robot: the robot.
        frame: frame name.
    """

    dim = 6

    def __init__(self, robot: Robot, frame: str) -> None:
        super().__init__(robot, f"pose({frame})")
        self.frame = frame
        self.frame_id = robot.frame_id(frame)

    def check_target(self, target: Any) -> pin.SE3:
        """Accepts ``pin.SE3``, a 4x4 matrix, ``[x, y, z]`` or ``[x, y, z, qx, qy, qz, qw]``."""
        name = f"target of feature '{self.name}'"
        return as_se3(target if isinstance(target, pin.SE3) else as_float_array(target, name), name)

    def value(self, state: State) -> pin.SE3:
        """The frame pose (a copy)."""
        self._check_state(state)
        return state.frame_placement(self.frame_id).copy()

    def jacobian(self, state: State) -> FloatArray:
        """6 x nv LOCAL Jacobian."""
        self._check_state(state)
        return state.frame_jacobian_local(self.frame_id)

    def compiled_term(self) -> CompiledTerm:
        """The kernel evaluates the frame pose error and its LOCAL Jacobian."""
        return CompiledTerm("pose", self.frame_id)

    def drift(self, state: State) -> FloatArray:
        """Body spatial acceleration at zero joint acceleration (LOCAL)."""
        self._check_state(state)
        return state.frame_drift_local(self.frame_id)

    def residual(self, state: State, target: Any) -> FloatArray:
        """``log6(T*^-1 T)`` (position error [m], rotation vector [rad])."""
        self._check_state(state)
        error = target.actInv(state.frame_placement(self.frame_id))
        return np.asarray(pin.log6(error).vector)

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """``log6(T*^-1 T)`` and ``Jlog6(T*^-1 T) J_local`` from one error computation."""
        if state.robot is not self.robot:
            self._check_state(state)
        fid = self.frame_id
        error = target.actInv(state.frame_placement(fid))
        # ndarray.dot: half the call overhead of ``@`` on these small matrices.
        J = pin.Jlog6(error).dot(state.frame_jacobian_local(fid))
        return pin.log6(error).vector, J

    def residual_jacobian(self, state: State, target: Any) -> FloatArray:
        """``Jlog6(T*^-1 T) J_local``."""
        self._check_state(state)
        error = target.actInv(state.frame_placement(self.frame_id))
        return np.asarray(pin.Jlog6(error) @ state.frame_jacobian_local(self.frame_id))
