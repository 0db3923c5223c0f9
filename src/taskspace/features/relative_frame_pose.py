"""Pose of one frame in another (6-D relative frame task, pink's ``RelativeFrameTask``).

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
from taskspace.features.feature import Feature
from taskspace.model.world import as_se3

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class RelativeFramePose(Feature):
    """Pose ``T_AB = T_A^-1 T_B`` of frame B in frame A; residual ``log6(T*^-1 T_AB)``.

    The Jacobian is that of the body twist of ``T_AB`` (in B): ``J = J_B - Ad(T_AB^-1)
    J_A`` with ``J_A``, ``J_B`` the LOCAL frame Jacobians (rows linear then angular); the
    residual Jacobian is ``Jlog6(T*^-1 T_AB) J``. The drift (derivative of ``J v`` at zero
    joint acceleration) is ``a_B - Ad(T_BA) a_A + ad(nu) Ad(T_BA) nu_A`` with ``a_X`` the
    LOCAL drifts, ``nu_A`` the body twist of A and ``nu = J v``. The residual's first three
    entries are a position error [m] in B, the last three a rotation vector [rad].

    Args:
        robot: the robot.
        frame: frame B (the one that moves to the target).
        reference_frame: frame A (the target is expressed in it).
    """

    dim = 6

    def __init__(self, robot: Robot, frame: str, reference_frame: str) -> None:
        super().__init__(robot, f"relative_pose({frame}|{reference_frame})")
        self.frame = frame
        self.reference_frame = reference_frame
        self.frame_id = robot.frame_id(frame)
        self.reference_id = robot.frame_id(reference_frame)

    def check_target(self, target: Any) -> pin.SE3:
        """Accepts ``pin.SE3``, a 4x4 matrix, ``[x, y, z]`` or ``[x, y, z, qx, qy, qz, qw]``."""
        name = f"target of feature '{self.name}'"
        return as_se3(target if isinstance(target, pin.SE3) else as_float_array(target, name), name)

    def _relative(self, state: State) -> pin.SE3:
        return state.frame_placement(self.reference_id).actInv(state.frame_placement(self.frame_id))

    def value(self, state: State) -> pin.SE3:
        """``T_AB`` (a copy)."""
        self._check_state(state)
        return self._relative(state)

    def jacobian(self, state: State) -> FloatArray:
        """6 x nv Jacobian of the body twist of ``T_AB``."""
        self._check_state(state)
        T_BA = self._relative(state).inverse()
        J_A = state.frame_jacobian_local(self.reference_id)
        return np.asarray(state.frame_jacobian_local(self.frame_id) - T_BA.action.dot(J_A))

    def drift(self, state: State) -> FloatArray:
        """``a_B - Ad(T_BA) a_A + ad(nu) Ad(T_BA) nu_A`` (LOCAL to B)."""
        self._check_state(state)
        T_BA = self._relative(state).inverse()
        Ad = T_BA.action
        v = state.v
        nu_A = state.frame_jacobian_local(self.reference_id).dot(v)
        nu_B = state.frame_jacobian_local(self.frame_id).dot(v)
        moved = Ad.dot(nu_A)
        nu = pin.Motion(nu_B - moved)
        return np.asarray(
            state.frame_drift_local(self.frame_id)
            - Ad.dot(state.frame_drift_local(self.reference_id))
            + nu.cross(pin.Motion(moved)).vector
        )

    def residual(self, state: State, target: Any) -> FloatArray:
        """``log6(T*^-1 T_AB)`` (position error [m], rotation vector [rad])."""
        self._check_state(state)
        return np.asarray(pin.log6(target.actInv(self._relative(state))).vector)

    def residual_jacobian(self, state: State, target: Any) -> FloatArray:
        """``Jlog6(T*^-1 T_AB) J``."""
        self._check_state(state)
        error = target.actInv(self._relative(state))
        return np.asarray(pin.Jlog6(error).dot(self.jacobian(state)))
