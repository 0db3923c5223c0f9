"""G1BalanceEnv follows Robot.version: torque limits re-derived at reset, stale steps refused."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import StaleModelError
from taskspace.learning.envs import G1BalanceEnv
from taskspace.model.robot import Robot


def test_torque_limits_follow_set_limits() -> None:
    robot = Robot.load("g1")  # own copy: set_limits changes it
    env = G1BalanceEnv(robot)
    env.reset(seed=0)
    taus: list[np.ndarray] = []
    solve = env.controller.solve

    def spy(state):  # type: ignore[no-untyped-def]
        result = solve(state)
        taus.append(np.array(result.tau))
        return result

    env.controller.solve = spy  # type: ignore[method-assign]
    _, _, terminated, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert not terminated and info["max_torque_ratio"] <= 1.0 + 1e-9
    # the joint nearest its limit during the push recovery gets half the torque it used
    peak = np.abs(np.array(taus)).max(axis=0)
    actuated = robot.effort_limits > 0.0
    k = int(np.argmax(np.where(actuated, peak / np.where(actuated, robot.effort_limits, 1.0), 0)))
    effort = robot.effort_limits.copy()
    effort[k] = 0.5 * peak[k]
    robot.set_limits(effort=effort)
    with pytest.raises(StaleModelError, match="call reset") as err:
        env.step(np.zeros(3, dtype=np.float32))
    assert err.value.current_version == robot.version
    assert err.value.built_version != robot.version

    env.reset(seed=0)
    assert env.model_version == robot.version
    assert env.tau_max[k] == effort[k]
    taus.clear()
    _, _, terminated, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert not terminated and not info["qp_failures"]
    # the same push under the new limit: joint k is held at the value set above (it binds)
    used = float(np.abs(np.array(taus)[:, k]).max())
    assert used <= effort[k] * (1.0 + 1e-9)
    assert used == pytest.approx(effort[k], rel=1e-6)
