from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pinocchio as pin
import pytest
from gymnasium.utils.env_checker import check_env

from taskspace.errors import InvalidInputError
from taskspace.learning.envs import G1BalanceEnv
from taskspace.model import Robot


@pytest.fixture(scope="module")
def env(g1: Robot) -> G1BalanceEnv:
    return G1BalanceEnv(g1)


def test_passes_check_env_and_is_registered(env: G1BalanceEnv) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # unbounded observations
        check_env(env)
    assert gym.spec("taskspace/G1Balance-v0").max_episode_steps == 100


def test_recovers_from_a_push_and_carries_its_weight(env: G1BalanceEnv) -> None:
    obs, _ = env.reset(seed=0)
    assert np.linalg.norm(obs[3:5]) > 0.05  # the push moves the CoM
    for _ in range(50):
        obs, reward, terminated, _, info = env.step(np.zeros(3, dtype=np.float32))
        assert not terminated
    assert np.linalg.norm(obs[:3]) < 0.01 and np.linalg.norm(obs[3:]) < 0.01
    assert reward == pytest.approx(1.0, abs=0.01)
    # At rest the feet carry the robot's weight (Pinocchio's total mass).
    weight = pin.computeTotalMass(env.robot.model) * 9.81
    assert info["total_normal_force"] == pytest.approx(weight, rel=0.02)


def test_the_action_moves_the_com_reference(env: G1BalanceEnv) -> None:
    env.reset(seed=1)
    for _ in range(50):
        obs, _, terminated, _, _ = env.step(np.array([0.0, 1.0, 0.0], dtype=np.float32))
        assert not terminated
    assert obs[1] == pytest.approx(0.05, abs=0.005)  # c* = c0 + 0.05 a
    assert abs(obs[0]) < 0.005


def test_errors(env: G1BalanceEnv, panda: Robot) -> None:
    with pytest.raises(InvalidInputError, match="floating-base 'g1'"):
        G1BalanceEnv(panda)
    with pytest.raises(InvalidInputError, match="render_mode 'human' is not supported; use None"):
        G1BalanceEnv(env.robot, render_mode="human")
    with pytest.raises(InvalidInputError, match="multiple of sim_dt"):
        G1BalanceEnv(env.robot, dt=0.01, sim_dt=0.003)
