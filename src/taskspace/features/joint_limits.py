"""Penetration of joint limits (slide 2:52).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from taskspace._validation import FloatArray, check_positive
from taskspace.features.feature import Feature
from taskspace.model.versioning import ModelFollower

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class JointLimitPenetration(Feature):
    """``phi(q) = 1/m sum_i [m - q_i + q_low,i]_+ + [m + q_i - q_hi,i]_+``.

    Jacobian ``J_1i = -1/m [m - q_i + q_low > 0] + 1/m [m + q_i - q_hi > 0]``. Zero when
    every joint is at least ``m`` inside its limits. Summed over the 1-DoF joints with finite
    limits.

    Args:
        robot: the robot.
        margin: safety margin ``m`` [rad or m].
    """

    dim = 1

    def __init__(self, robot: Robot, margin: float = 0.1) -> None:
        super().__init__(robot, "joint_limit_penetration")
        self.margin = check_positive(margin, "margin")
        self._follower = ModelFollower(robot, "JointLimitPenetration", self._read_limits)

    def _read_limits(self) -> None:
        """Copy the robot's limits; re-read when ``Robot.set_limits`` changes its version."""
        robot = self.robot
        self._iq = robot.limited_joints_q
        self._iv = robot.limited_joints_v
        self._low = robot.lower_limits[self._iq]
        self._high = robot.upper_limits[self._iq]

    def _terms(self, state: State) -> tuple[FloatArray, FloatArray]:
        self._follower.sync()
        qi = state.q[self._iq]
        return self.margin - qi + self._low, self.margin + qi - self._high

    def value(self, state: State) -> FloatArray:
        """Penetration (dimensionless), shape (1,)."""
        self._check_state(state)
        below, above = self._terms(state)
        # each term divided by the margin before summing: with margin = 1e308 the sum of the
        # raw terms overflowed to inf although every ratio is about 1
        m = self.margin
        return np.array([(np.maximum(below, 0) / m).sum() + (np.maximum(above, 0) / m).sum()])

    def jacobian(self, state: State) -> FloatArray:
        """1 x nv Jacobian."""
        self._check_state(state)
        below, above = self._terms(state)
        J = np.zeros((1, self.robot.nv))
        J[0, self._iv] = (-(below > 0).astype(float) + (above > 0).astype(float)) / self.margin
        return J

    def drift(self, state: State) -> FloatArray:
        """Zero (the map is piecewise linear in q)."""
        self._check_state(state)
        return np.zeros(1)
