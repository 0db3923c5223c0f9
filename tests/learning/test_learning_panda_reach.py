from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from taskspace.learning.envs import PandaReachEnv
from taskspace.model.robot import Robot


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda")


def test_check_env_and_registration(panda: Robot) -> None:
    env = gym.make("taskspace/PandaReach-v0", robot=panda)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        check_env(env.unwrapped)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (13,)
    # The observed tool position is Pinocchio's forward kinematics of the observed q.
    tcp = panda.frame_placement(obs[:7].astype(float), "panda_hand_tcp").translation
    assert obs[7:10] == pytest.approx(tcp, abs=1e-5)


def test_reaching_with_a_jacobian_controller_succeeds(panda: Robot) -> None:
    import pinocchio as pin

    env = PandaReachEnv(robot=panda)
    env.reset(seed=1)
    model, data = panda.model, panda.model.createData()
    fid = model.getFrameId("panda_hand_tcp")
    for _ in range(100):
        J = pin.computeFrameJacobian(model, data, env.q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        err = env.target - env.tcp()
        v = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(3), 2.0 * err)
        _, reward, terminated, _, info = env.step(np.clip(v / env.v_max, -1, 1))
        if terminated:
            break
    assert info["success"] and reward > 0


def test_collision_terminates(panda: Robot) -> None:
    env = PandaReachEnv(robot=panda)
    env.reset(seed=2)
    # Head straight for a self-colliding configuration: the first colliding step ends it.
    rng = np.random.default_rng(0)
    while True:
        bad = rng.uniform(env.lower, env.upper)
        if not env.checker.is_valid(bad):
            break
    info: dict = {}
    reward = 0.0
    for _ in range(200):
        step = (bad - env.q) / (env.dt * env.v_max)
        _, reward, terminated, _, info = env.step(np.clip(step, -1, 1).astype(np.float32))
        if terminated:
            break
    assert info["collision"] and not info["success"]
    assert reward < -10.0 + 1e-9
    assert not env.checker.is_valid(env.q)
