"""CMA-ES (pycma) on a linear cart-pole policy, on our ABA cart-pole and Gymnasium's
CartPole-v1: learning curves.

Policy: push right iff ``theta^T obs > 0`` (4 parameters); each candidate's return is one
episode (at most 500 steps) with a fixed seed; rollouts are pure functions of
(parameters, seed).
"""

from __future__ import annotations

import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

import taskspace.learning.envs  # noqa: F401  (registers taskspace/CartPole-v0)
from taskspace.learning import Episode, PolicySearchOptions, cma_es


def make_rollout(env_id: str):  # type: ignore[no-untyped-def]
    env = gym.make(env_id)

    def rollout(theta: np.ndarray, seed: int) -> Episode:
        obs, _ = env.reset(seed=int(seed))
        total, steps = 0.0, 0
        while True:
            obs, r, term, trunc, _ = env.step(int(np.dot(theta, obs) > 0))
            total += float(r)
            steps += 1
            if term or trunc:
                break
        return Episode(
            total_return=total,
            log_likelihood_gradient=np.zeros(4),
            rewards=np.zeros(0),
            steps=steps,
        )

    return rollout


def main() -> None:
    args = parse(__doc__ or "")
    iterations = 8 if fast() else 30
    fig, ax = plt.subplots(figsize=(7, 4))
    for env_id in ("taskspace/CartPole-v0", "CartPole-v1"):
        res = cma_es(
            make_rollout(env_id),
            np.zeros(4),
            PolicySearchOptions(iterations=iterations, population=10, exploration=0.5, seed=1),
        )
        steps = np.cumsum([0, *[10] * len(res.mean_returns)])[1:]
        ax.plot(steps, res.mean_returns, "o-", label=f"{env_id} ({res.environment_steps} steps)")
    ax.set_xlabel("rollouts")
    ax.set_ylabel("mean return of the population")
    ax.set_title("CMA-ES on a linear policy (500 = balanced for the whole episode)")
    ax.legend()
    fig.tight_layout()
    finish({"cartpole_cma_es": fig}, args.save)


if __name__ == "__main__":
    main()
