"""Robot.lower_limits/upper_limits read -inf/+inf where the robot treats a joint as unlimited.

example-robot-data's double_pendulum has no limits in its URDF (Pinocchio keeps ``(0, 0)``);
the robot warns and treats both joints as unbounded (it accepts and samples angles away from
0). The old ``lower_limits``/``upper_limits`` still read ``(0, 0)``, so a reader that clips
into them (the path optimizer's repair step, ``np.clip(q, lower, upper)``) silently pinned both
joints at 0.
"""

from __future__ import annotations

import warnings

import numpy as np

from taskspace.model import Robot


def _pendulum() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("double_pendulum", geometry=False)


def test_equal_limits_read_as_unbounded() -> None:
    robot = _pendulum()
    assert np.all(np.asarray(robot.model.lowerPositionLimit) == 0.0)  # the description's (0, 0)
    assert robot.limited_joints_q.size == 0
    q = np.array([2.0, -2.5])
    robot.check_configuration(q, "q")  # the robot accepts angles away from 0
    np.testing.assert_array_equal(robot.lower_limits, [-np.inf, -np.inf])
    np.testing.assert_array_equal(robot.upper_limits, [np.inf, np.inf])
    np.testing.assert_array_equal(np.clip(q, robot.lower_limits, robot.upper_limits), q)


def test_limited_robot_keeps_its_limits(panda: Robot) -> None:
    np.testing.assert_array_equal(panda.lower_limits, np.asarray(panda.model.lowerPositionLimit))
    np.testing.assert_array_equal(panda.upper_limits, np.asarray(panda.model.upperPositionLimit))
