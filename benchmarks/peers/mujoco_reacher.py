"""Gymnasium's MuJoCo reacher peer for the learning suite (runs in .venv-peers/sb3).

Prints one JSON line with per-step timings (seconds) of ``Reacher-v5`` (MuJoCo, frame skip 2,
2-link planar arm, random actions): ``single``, one ``step`` of one unwrapped env (as the
suite's own single-env rows: no time limit, so no reset), mean of blocks of 50 steps;
``sync_<N>``, one step of ``N`` copies in gymnasium's ``SyncVectorEnv`` (the per-copy loop this
peer offers; its 50-step time limit auto-resets copies, ours every 100 steps). Usage:
``python mujoco_reacher.py ROUNDS NUM_ENVS``.
"""

from __future__ import annotations

import json
import sys
import time

import gymnasium as gym
import numpy as np


def main() -> None:
    rounds, n = int(sys.argv[1]), int(sys.argv[2])
    env = gym.make("Reacher-v5").unwrapped
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(256)]
    k = 0

    def step() -> None:
        nonlocal k
        _, _, term, trunc, _ = env.step(actions[k & 255])
        k += 1
        if term or trunc:  # never for the unwrapped Reacher (its 50-step limit is a wrapper)
            env.reset()

    for _ in range(200):
        step()
    single = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(50):
            step()
        single.append((time.perf_counter() - t0) / 50)
    vec = gym.make_vec("Reacher-v5", num_envs=n, vectorization_mode="sync")
    vec.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (16, n, 2)).astype(np.float32)
    for i in range(5):
        vec.step(acts[i & 15])
    batched = []
    for i in range(max(rounds // 5, 5)):
        t0 = time.perf_counter()
        vec.step(acts[i & 15])
        batched.append(time.perf_counter() - t0)
    print(json.dumps({"single": single, f"sync_{n}": batched, "mujoco": _version()}))


def _version() -> str:
    import mujoco

    return str(mujoco.__version__)


if __name__ == "__main__":
    main()
