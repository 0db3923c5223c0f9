"""Stable-Baselines3 PPO on our pendulum and Gymnasium's (runs in .venv-peers/sb3).

The sample-efficiency reference of the learning suite: PPO (SB3 2.x, CPU torch, one thread)
with the RL Baselines3 Zoo hyperparameters of ``Pendulum-v1`` (4 envs x 1024 steps per update,
gamma 0.9, GAE 0.95, 10 epochs, lr 1e-3, clip 0.2, gSDE resampled every 4 steps), trained for
``TIMESTEPS`` environment steps on ``taskspace/Pendulum-v0`` (our Pinocchio pendulum, torque
bound 5 N m) and on ``Pendulum-v1`` (Gymnasium's, torque bound 2 N m: a harder swing-up), then
evaluated deterministically on 10 episodes of 200 steps. taskspace is imported from this
checkout's ``src``.

The ``sb3`` peer environment (not in ``install.sh`` yet), from the project root::

    python3 -m venv .venv-peers/sb3
    .venv-peers/sb3/bin/pip install torch stable-baselines3 gymnasium==1.4.0 mujoco imageio \
        packaging    # torch: its CPU-only build (a local wheel or the CPU package index)
    .venv-peers/sb3/bin/pip install pin==4.1.0 coal==3.0.3 proxsuite==0.8.0 qpsolvers osqp \
        daqp quadprog scipy example-robot-data==5.0.0 example-robot-data-loaders==5.0.0 \
        pyyaml tqdm cma    # taskspace's dependencies, the versions of taskspace's .venv

(``mujoco``, ``imageio`` and ``packaging`` serve ``benchmarks/peers/mujoco_reacher.py``.)

Prints one JSON line: per env id, the seeds' ``eval_return`` (mean over the 10 episodes),
``curve`` (mean training-episode return per update), ``wall_s`` and ``env_step_s`` (time spent
inside the environments' ``step``). Usage:
``python sb3_ppo.py TIMESTEPS SEEDS [ENV_ID ...]``.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from _checkout import use_checkout
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

ROOT = use_checkout()  # src/ and the built kernels (a fair checker for the peer)

import taskspace.learning.envs  # noqa: E402, F401  (registers taskspace/Pendulum-v0)

ZOO_PENDULUM: dict[str, Any] = {
    "n_steps": 1024,
    "gae_lambda": 0.95,
    "gamma": 0.9,
    "n_epochs": 10,
    "ent_coef": 0.0,
    "learning_rate": 1e-3,
    "clip_range": 0.2,
    "use_sde": True,
    "sde_sample_freq": 4,
}


class StepTimer(gym.Wrapper):  # type: ignore[type-arg]
    """Accumulates the time spent in the wrapped env's ``step``."""

    total = 0.0

    def step(self, action: Any) -> Any:
        t0 = time.perf_counter()
        out = self.env.step(action)
        StepTimer.total += time.perf_counter() - t0
        return out


class Curve(BaseCallback):
    """Mean return of the training episodes finished during each rollout."""

    def __init__(self) -> None:
        super().__init__()
        self.curve: list[float] = []

    def _on_rollout_end(self) -> None:
        buf = self.model.ep_info_buffer
        if buf:
            self.curve.append(float(np.mean([e["r"] for e in buf])))

    def _on_step(self) -> bool:
        return True


def evaluate(model: PPO, env_id: str, seed: int, episodes: int = 10) -> float:
    env = gym.make(env_id)
    returns = []
    for k in range(episodes):
        obs, _ = env.reset(seed=10_000 + 100 * seed + k)
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, r, term, trunc, _ = env.step(action)
            total += float(r)
            done = term or trunc
        returns.append(total)
    return float(np.mean(returns))


def run(env_id: str, timesteps: int, seed: int) -> dict[str, Any]:
    StepTimer.total = 0.0
    venv = make_vec_env(
        env_id, n_envs=4, seed=seed, wrapper_class=StepTimer, env_kwargs={"render_mode": None}
    )
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", verbose=0, **ZOO_PENDULUM)
    curve = Curve()
    t0 = time.perf_counter()
    model.learn(total_timesteps=timesteps, callback=curve)
    wall = time.perf_counter() - t0
    return {
        "eval_return": evaluate(model, env_id, seed),
        "curve": curve.curve,
        "wall_s": wall,
        "env_step_s": StepTimer.total,
    }


def main() -> None:
    torch.set_num_threads(1)
    timesteps, seeds = int(sys.argv[1]), int(sys.argv[2])
    env_ids = sys.argv[3:] or ["taskspace/Pendulum-v0", "Pendulum-v1"]
    out: dict[str, Any] = {"timesteps": timesteps, "versions": _versions()}
    for env_id in env_ids:
        runs = [run(env_id, timesteps, seed) for seed in range(seeds)]
        out[env_id] = {key: [r[key] for r in runs] for key in runs[0]}
    print(json.dumps(out))


def _versions() -> dict[str, str]:
    import stable_baselines3

    return {"stable_baselines3": stable_baselines3.__version__, "torch": torch.__version__}


if __name__ == "__main__":
    main()
