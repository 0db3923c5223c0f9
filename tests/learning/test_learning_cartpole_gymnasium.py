"""The batched cart-pole configured like Gymnasium's CartPole-v1 (``model="gymnasium"``) steps
exactly as Gymnasium's own CartPole-v1 / CartPoleVectorEnv (installed in the test venv)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning.envs import CartPoleVectorEnv

gym = pytest.importorskip("gymnasium")
cartpole = pytest.importorskip("gymnasium.envs.classic_control.cartpole")


def _set(ours: CartPoleVectorEnv, S: np.ndarray) -> None:
    """Gymnasium's state order (x, x', theta, theta') -> our q = (x, theta), v = (x', theta')."""
    ours.q = S[:, [0, 2]].copy()
    ours.v = S[:, [1, 3]].copy()


def _state(ours: CartPoleVectorEnv) -> np.ndarray:
    return np.stack([ours.q[:, 0], ours.v[:, 0], ours.q[:, 1], ours.v[:, 1]], axis=1)


def test_one_step_equals_gymnasium_from_random_states() -> None:
    n = 64
    rng = np.random.default_rng(0)
    S = rng.uniform([-2.0, -2.0, -0.2, -2.0], [2.0, 2.0, 0.2, 2.0], (n, 4))
    acts = rng.integers(0, 2, n)
    ours = CartPoleVectorEnv(n, model="gymnasium")
    assert ours.substeps == 1 and ours.dt == 0.02
    ours.reset(seed=0)
    _set(ours, S)
    obs, rew, term, trunc, _ = ours.step(acts)
    # Gymnasium's vector env: the same array operations, equal to the last bit.
    theirs = cartpole.CartPoleVectorEnv(num_envs=n)
    theirs.reset(seed=0)
    theirs.state = S.T.copy()
    tobs, _, tterm, _, _ = theirs.step(acts)
    assert np.array_equal(_state(ours), theirs.state.T)
    assert np.array_equal(obs, tobs) and np.array_equal(term, tterm)
    assert np.all(rew == 1.0) and not np.any(trunc)
    # Gymnasium's single CartPole-v1, copy by copy (numpy scalar maths: round-off level).
    single = gym.make("CartPole-v1").unwrapped
    single.reset(seed=0)
    for i in range(n):
        single.state = S[i].copy()
        single.steps_beyond_terminated = None
        sobs, _, sterm, _, _ = single.step(int(acts[i]))
        assert _state(ours)[i] == pytest.approx(single.state, rel=1e-13, abs=1e-15)
        assert sterm == term[i]
        assert sobs == pytest.approx(obs[i], rel=1e-6)
    # The default (URDF point-mass pole, semi-implicit Euler, 2 substeps) is another model.
    urdf = CartPoleVectorEnv(n)
    urdf.reset(seed=0)
    _set(urdf, S)
    urdf.step(acts)
    assert urdf.substeps == 2
    assert np.max(np.abs(_state(urdf) - theirs.state.T)) > 1e-3


def test_trajectory_equals_gymnasium_cartpole_v1() -> None:
    # 200 steps of a bang-bang balancing policy from Gymnasium's own reset state.
    single = gym.make("CartPole-v1").unwrapped
    obs, _ = single.reset(seed=3)
    ours = CartPoleVectorEnv(1, model="gymnasium")
    ours.reset(seed=0)
    _set(ours, np.asarray(single.state, dtype=float)[None])
    steps = 0
    for _ in range(200):
        a = int(obs[2] + 0.5 * obs[3] > 0)
        obs, _, term, _, _ = single.step(a)
        mine, _, mterm, _, _ = ours.step(np.array([a]))
        assert _state(ours)[0] == pytest.approx(single.state, rel=1e-12, abs=1e-14)
        assert mterm[0] == term
        assert mine[0] == pytest.approx(obs, rel=1e-6)
        steps += 1
        if term:
            break
    assert steps == 200  # the policy balances: the whole run was compared


def test_model_errors_and_defaults() -> None:
    with pytest.raises(InvalidInputError, match="valid: \\('urdf', 'gymnasium'\\)"):
        CartPoleVectorEnv(2, model="mujoco")
    assert CartPoleVectorEnv(2, model="gymnasium", substeps=4).substeps == 4
    env = gym.make_vec(
        "taskspace/CartPole-v0",
        num_envs=3,
        vectorization_mode="vector_entry_point",
        model="gymnasium",
    )
    assert env.unwrapped.model == "gymnasium" and env.unwrapped.substeps == 1
    env.close()
