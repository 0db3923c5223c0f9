"""Issue #22 audit: a pose goal region holds exactly the configurations within its tolerances.

The planners end a path where ``GoalRegion.contains`` says so, so ``contains`` decides whether
"goal regions are reached within their tolerances". Reference, independent of
``PoseGoalRegion``: Pinocchio's ``framesForwardKinematics`` on a fresh ``Data``, the position
error as a norm and the rotation angle from the trace of the relative rotation
(``arccos((tr R - 1) / 2)``, not ``log3``). Configurations are drawn around one that meets the
target exactly, at distances that put about half of them outside; doubling either tolerance
in ``contains`` fails the test (audit, stop 23: the goal-region tests passed with the position
tolerance doubled).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.model import Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

FRAME = "panda_hand_tcp"
POS_TOL, ROT_TOL = 0.01, 0.05


@pytest.fixture(scope="module")
def robot() -> Robot:
    return Robot.load("panda", convex_collision=True)


def _reference_errors(robot: Robot, q: np.ndarray, target: pin.SE3) -> tuple[float, float]:
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    placement = data.oMf[model.getFrameId(FRAME)]
    position = float(np.linalg.norm(placement.translation - target.translation))
    rel = target.rotation.T @ placement.rotation
    angle = float(np.arccos(np.clip((np.trace(rel) - 1.0) / 2.0, -1.0, 1.0)))
    return position, angle


def _target(robot: Robot) -> tuple[np.ndarray, pin.SE3]:
    q_star = robot.q_default.copy()
    q_star[:7] = [0.3, -0.4, 0.2, -2.0, 0.1, 1.8, 0.5]
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q_star)
    return q_star, pin.SE3(data.oMf[model.getFrameId(FRAME)])


def test_contains_is_the_tolerance_test_of_forward_kinematics(robot: Robot) -> None:
    q_star, target = _target(robot)
    region = PoseGoalRegion(
        robot, FRAME, target, position_tolerance=POS_TOL, rotation_tolerance=ROT_TOL
    )
    rng = np.random.default_rng(0)
    inside = outside = 0
    for scale in np.geomspace(1e-3, 0.1, 400):
        q = q_star.copy()
        q[:7] += scale * rng.standard_normal(7)
        position, angle = _reference_errors(robot, q, target)
        if min(abs(position - POS_TOL), abs(angle - ROT_TOL)) < 1e-9:
            continue  # on a boundary: either answer is right
        expected = position <= POS_TOL and angle <= ROT_TOL
        assert region.contains(q) == expected, (position, angle)
        inside += expected
        outside += not expected
    # both sides, and both tolerances binding somewhere
    assert inside > 50 and outside > 50


def test_samples_and_planned_ends_are_within_the_tolerances(robot: Robot) -> None:
    _, target = _target(robot)
    region = PoseGoalRegion(
        robot, FRAME, target, position_tolerance=POS_TOL, rotation_tolerance=ROT_TOL
    )
    rng = np.random.default_rng(1)
    for _ in range(3):
        q = region.sample(rng)
        assert q is not None
        position, angle = _reference_errors(robot, q, target)
        assert position <= POS_TOL + 1e-12 and angle <= ROT_TOL + 1e-12
    space = ConfigurationSpace.from_robot(robot)
    result = rrt_connect(
        space, robot.q_default, region, RRTConnectOptions(time_limit_s=5.0, seed=0)
    )
    assert result.success
    position, angle = _reference_errors(robot, result.path[-1], target)
    assert position <= POS_TOL + 1e-12 and angle <= ROT_TOL + 1e-12
