"""PandaReach with joints the robot reads as unlimited (Robot.set_limits with +-inf).

Position limits of +-inf are honest bounds (the observation box's q entries are infinite, the
joint moves at its velocity limit without clipping). An infinite velocity limit has no
meaning for an action that is a fraction of it: v = a * inf made joint 2 jump to its position
limit in one step, and a = 0 gave 0 * inf = NaN (a NotFiniteError from the kinematics). Both
environments now refuse it, naming the joint.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning.envs import PandaReachEnv
from taskspace.learning.envs.panda_reach import PandaReachVectorEnv
from taskspace.model.robot import Robot


@pytest.fixture(scope="module")
def robot() -> Robot:
    return Robot.load("panda")  # own copy: set_limits changes it


def test_unlimited_position_is_an_infinite_box_entry_and_no_clip(robot: Robot) -> None:
    lower, upper = robot.lower_limits.copy(), robot.upper_limits.copy()
    lower[0], upper[0] = -np.inf, np.inf
    robot.set_limits(lower=lower, upper=upper, velocity=robot.velocity_limits)
    env = PandaReachEnv(robot=robot)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.low[0] == -np.inf and env.observation_space.high[0] == np.inf
    assert env.observation_space.contains(obs)
    q0 = env.q[0]
    for _ in range(30):  # 3 s at full speed: far past the Panda's own 2.9 rad limit
        obs, *_ = env.step(np.eye(7, dtype=np.float32)[0])
    assert env.q[0] == pytest.approx(q0 + 30 * env.dt * robot.velocity_limits[0])
    assert np.all(np.isfinite(obs))


@pytest.mark.parametrize("vector", [False, True])
def test_unlimited_velocity_is_refused_naming_the_joint(robot: Robot, vector: bool) -> None:
    velocity = robot.velocity_limits.copy()
    velocity[1] = np.inf
    robot.set_limits(velocity=velocity)
    name = robot.joint_names[1]
    with pytest.raises(InvalidInputError, match=f"finite velocity limit.*'{name}'"):
        PandaReachVectorEnv(2, robot=robot) if vector else PandaReachEnv(robot=robot)


def test_unlimited_velocity_after_reset_is_refused_at_the_next_reset(robot: Robot) -> None:
    velocity = robot.velocity_limits.copy()
    velocity[1] = 2.0
    robot.set_limits(velocity=velocity)
    env = PandaReachEnv(robot=robot)
    env.reset(seed=0)
    velocity[1] = np.inf
    robot.set_limits(velocity=velocity)
    with pytest.raises(InvalidInputError, match="finite velocity limit"):
        env.reset(seed=0)
