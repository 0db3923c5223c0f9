"""PandaReachEnv follows Robot.version: limits re-derived at reset, stale steps refused."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import StaleModelError
from taskspace.learning.envs import PandaReachEnv
from taskspace.model.robot import Robot


def test_limits_follow_set_limits() -> None:
    robot = Robot.load("panda")  # own copy: set_limits changes it
    env = PandaReachEnv(robot=robot)
    env.reset(seed=0)
    env.step(np.zeros(7, dtype=np.float32))
    q0 = env.q.copy()
    # Narrow joint 1 to a band around the current posture and halve every velocity limit.
    upper = robot.upper_limits.copy()
    upper[0] = q0[0] + 0.05
    velocity = 0.5 * robot.velocity_limits
    robot.set_limits(upper=upper, velocity=velocity)
    with pytest.raises(StaleModelError, match="call reset") as err:
        env.step(np.zeros(7, dtype=np.float32))
    assert err.value.current_version == robot.version
    assert err.value.built_version != robot.version

    obs, _ = env.reset(seed=0)
    assert env.model_version == robot.version
    assert env.upper[0] == pytest.approx(q0[0] + 0.05)
    assert env.v_max == pytest.approx(velocity)
    assert env.observation_space.high[0] == pytest.approx(q0[0] + 0.05, abs=1e-6)
    assert env.observation_space.contains(obs)
    # Full speed on joint 1 for 1 s: stopped at the new upper limit, moved at the new speed.
    for _ in range(10):
        env.step(np.eye(7, dtype=np.float32)[0])
    assert env.q[0] == pytest.approx(q0[0] + 0.05)
    env.reset(seed=0)
    q_start = env.q.copy()
    env.step(-np.eye(7, dtype=np.float32)[1])
    assert env.q[1] == pytest.approx(q_start[1] - env.dt * velocity[1])
