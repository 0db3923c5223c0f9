"""T-maze (gamma = 0.5): exact values by value iteration, and what Q-learning and TD(lambda)
learn from samples.

The maze is a reconstruction (see :func:`taskspace.optimal_control.t_maze`): the lecture
notes' exercise is not in the project's copy of the notes.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.learning import TabularOptions, q_learning, td_lambda
from taskspace.optimal_control import evaluate_policy, t_maze, value_iteration


def main() -> None:
    args = parse(__doc__ or "")
    mdp = t_maze(gamma=0.5)
    exact = value_iteration(mdp)
    episodes = 100 if fast() else 500
    rng = np.random.default_rng(0)
    ql = q_learning(mdp, TabularOptions(episodes=episodes, max_steps=20, epsilon=1.0), rng=rng)
    td = td_lambda(
        mdp, exact.policy, TabularOptions(episodes=episodes, max_steps=20, trace_decay=0.7), rng=rng
    )
    names = list(mdp.state_names)
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(x - 0.25, exact.V, 0.25, label="value iteration")
    ax.bar(x, ql.V, 0.25, label=f"Q-learning ({episodes} episodes)")
    ax.bar(x + 0.25, td.V, 0.25, label="TD(0.7) of the optimal policy")
    ax.plot(x, evaluate_policy(mdp, exact.policy), "k_", ms=20, label="exact V of that policy")
    ax.set_xticks(x, names)
    ax.set_ylabel("V(s)")
    ax.set_title("T-maze, gamma = 0.5: left arm pays 1 after 1 step, right arm 3 after 2")
    ax.legend()
    fig.tight_layout()
    finish({"t_maze_values": fig}, args.save)


if __name__ == "__main__":
    main()
