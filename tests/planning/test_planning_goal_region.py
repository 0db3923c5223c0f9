"""RRT* to a Panda tool pose within tolerances, goal configurations sampled by IK."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.rrt_star import GoalRegion, RRTStarOptions, rrt_star


def test_panda_reaches_a_pose_region_around_an_obstacle() -> None:
    robot = Robot.load("panda", convex_collision=True)
    start = robot.q_default
    tcp = robot.frame_id("panda_hand_tcp")
    here = robot.state(start).frame_placement(tcp)
    # a block halfway along the straight move of the hand
    block = here.translation + np.array([0.0, 0.15, 0.0])
    robot.add_obstacle(Obstacle.box("block", [0.08, 0.04, 0.08], block))
    space = ConfigurationSpace.from_robot(robot)
    goal_pose = pin.SE3(here.rotation, here.translation + np.array([0.0, 0.3, 0.0]))
    region = PoseGoalRegion(
        robot, "panda_hand_tcp", goal_pose, position_tolerance=0.02, rotation_tolerance=0.1
    )
    assert isinstance(region, GoalRegion)
    assert not region.contains(start)
    result = rrt_star(
        space,
        start,
        region,
        RRTStarOptions(max_iterations=400, time_limit_s=None, goal_bias=0.2, seed=2),
    )
    assert result.success
    end = result.path[-1]
    position, rotation = region.errors(end)
    assert position <= 0.02 and rotation <= 0.1
    # independent: Pinocchio's forward kinematics of the last configuration
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, end)
    assert np.linalg.norm(data.oMf[tcp].translation - goal_pose.translation) <= 0.02 + 1e-9
    assert space.path_valid(result.path)
