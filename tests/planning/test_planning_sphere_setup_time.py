"""The sphere checker's set-up is not spent from a plan's time limit.

A first plan with a sphere checker for a robot whose spheres are not cached fits them (about
2 s for the UR5). That fit ran inside the plan's clock: with a 1 s limit the plan ended with
TIME_LIMIT after 0 iterations (found by a new-user audit). It is set-up, as OMPL's setup()
before solve(): built before the clock starts. The path is checked with Pinocchio's
computeCollisions every 0.01 rad, independent of the sphere checker.
"""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.sphere_model import SPHERE_CACHE_ENVIRONMENT_VARIABLE


def test_a_first_sphere_plan_is_not_spent_on_fitting_the_spheres(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(SPHERE_CACHE_ENVIRONMENT_VARIABLE, "0")  # fit now, whatever the cache
    robot = Robot.load("ur5")  # a new robot object: its spheres are not in the process cache
    robot.add_obstacle(
        Obstacle.box("wall", [0.1, 1.0, 0.4], pin.SE3(np.eye(3), np.r_[0.5, 0, 0.2]))
    )
    space = ConfigurationSpace.from_robot(robot)
    start = robot.q_default.copy()
    goal = start.copy()
    goal[0] += 1.0
    opts = RRTConnectOptions(checker="spheres_only", validator="spheres", time_limit_s=0.05, seed=1)
    result = rrt_connect(space, start, goal, opts)
    assert result.success, result.status
    assert result.log["native"] == 1.0 and result.time_s < 0.05
    data = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(result.path):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / 0.01)) + 1)
        for t in np.linspace(0.0, 1.0, n):
            q = a + t * (b - a)
            assert not pin.computeCollisions(
                robot.model, data[0], robot.collision_model, data[1], q, True
            )
