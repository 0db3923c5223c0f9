from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pinocchio as pin
import pytest
from gymnasium.utils.env_checker import check_env

from taskspace.dynamics.pendulum import pendulum_acceleration
from taskspace.errors import InvalidInputError
from taskspace.learning.envs import CartPoleEnv, CartPoleVectorEnv, PendulumEnv, PendulumVectorEnv
from taskspace.optimal_control import cartpole_acceleration


@pytest.mark.parametrize("env_id", ["taskspace/Pendulum-v0", "taskspace/CartPole-v0"])
def test_registered_envs_pass_check_env(env_id: str) -> None:
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # unbounded velocities, as CartPole-v1
        check_env(env.unwrapped)
    assert env.spec is not None and env.spec.max_episode_steps in (200, 500)


@pytest.mark.parametrize("env_id", ["taskspace/Pendulum-v0", "taskspace/CartPole-v0"])
def test_seeded_episodes_are_reproducible(env_id: str) -> None:
    def run(seed: int) -> np.ndarray:
        env = gym.make(env_id)
        env.action_space.seed(seed)
        obs, _ = env.reset(seed=seed)
        out = [obs]
        for _ in range(30):
            obs, _, term, trunc, _ = env.step(env.action_space.sample())
            out.append(obs)
            if term or trunc:
                break
        return np.array(out)

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_pendulum_dynamics_match_the_closed_form() -> None:
    env = PendulumEnv(dt=1e-3, substeps=1)
    env.reset(seed=0)
    env.state = np.array([0.7, 0.3])
    env.step(np.array([1.5], dtype=np.float32))
    acc = float(pendulum_acceleration(0.7, 1.5))
    assert env.state[1] == pytest.approx(0.3 + 1e-3 * acc, rel=1e-9)
    assert env.state[0] == pytest.approx(0.7 + 1e-3 * env.state[1], rel=1e-9)
    # Upright at rest costs nothing and observes [1, 0, 0].
    env.state = np.array([np.pi, 0.0])
    obs, reward, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert reward == pytest.approx(0.0)
    assert obs == pytest.approx([1.0, 0.0, 0.0], abs=1e-3)


def test_cartpole_closed_form_matches_aba() -> None:
    env = CartPoleEnv()
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, (20, 2))
    v = rng.uniform(-2, 2, (20, 2))
    F = rng.uniform(-10, 10, 20)
    ours = cartpole_acceleration(q, v, F)
    ref = np.array(
        [pin.aba(env.model, env.data, q[k], v[k], np.array([F[k], 0.0])) for k in range(20)]
    )
    assert ours == pytest.approx(ref, rel=1e-9, abs=1e-9)


def test_vector_env_matches_the_single_env() -> None:
    vec = CartPoleVectorEnv(num_envs=3)
    vec.reset(seed=0)
    single = CartPoleEnv()
    single.reset(seed=0)
    single.q, single.v = vec.q[1].copy(), vec.v[1].copy()
    rng = np.random.default_rng(1)
    for _ in range(20):
        acts = rng.integers(0, 2, 3)
        obs, _, term, _, _ = vec.step(acts)
        o1, *_ = single.step(int(acts[1]))
        assert obs[1] == pytest.approx(o1, abs=1e-6)
        if term[1]:
            break


def test_pendulum_vector_env_matches_the_single_env() -> None:
    vec = PendulumVectorEnv(num_envs=4)
    vec.reset(seed=0)
    single = PendulumEnv()
    single.reset(seed=0)
    single.state = vec.state[2].copy()
    rng = np.random.default_rng(1)
    for _ in range(30):
        u = rng.uniform(-5, 5, (4, 1)).astype(np.float32)
        obs, rew, *_ = vec.step(u)
        o1, r1, *_ = single.step(u[2])
        assert obs[2] == pytest.approx(o1, abs=1e-5)
        assert rew[2] == pytest.approx(r1, rel=1e-6)
    made = gym.make_vec(
        "taskspace/Pendulum-v0", num_envs=3, vectorization_mode="vector_entry_point"
    )
    obs, _ = made.reset(seed=0)
    assert obs.shape == (3, 3)


def test_vector_env_via_make_vec_and_autoreset() -> None:
    vec = gym.make_vec("taskspace/CartPole-v0", num_envs=8, vectorization_mode="vector_entry_point")
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (8, 4)
    ended = np.zeros(8, dtype=bool)
    for _ in range(100):
        obs, rew, term, trunc, _ = vec.step(np.ones(8, dtype=np.int64))  # always push right
        if np.any(ended):
            assert np.all(rew[ended] == 0.0)  # the reset step
            assert np.all(np.abs(obs[ended]) <= 0.05)
        ended = term | trunc
    assert vec.unwrapped.steps.max() < 100  # every copy fell and was reset


def test_errors() -> None:
    with pytest.raises(InvalidInputError, match="render_mode"):
        PendulumEnv(render_mode="human")
    env = CartPoleEnv()
    env.reset(seed=0)
    with pytest.raises(InvalidInputError, match="0 or 1"):
        env.step(3)
