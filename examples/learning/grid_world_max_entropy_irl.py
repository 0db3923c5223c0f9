"""Maximum-entropy inverse RL on a grid world: the reward is recovered from demonstrations.

A 6 x 6 grid world (four moves, walls) with a reward that is linear in four state features
(Gaussian bumps around four cells). The expert is soft-optimal for ``beta w`` over 8-step
episodes from uniformly random cells (slip 0.1); 2,000 demonstrations are sampled from it.
Maximum (causal) entropy IRL fits the weights to the demonstrations' feature counts. The
figure shows the true and the recovered rewards (normalized: the scale ``beta`` cannot be
told from demonstrations) and the state visits of the expert and of the learned soft policy.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.learning import (
    demonstration_feature_counts,
    expected_feature_counts,
    max_entropy_irl,
    soft_value_iteration,
)
from taskspace.optimal_control import grid_world

LAYOUT = ["......", ".##...", "......", "...#..", "...#..", "......"]
HORIZON = 8


def sample(mdp, policy, start, n, rng):  # type: ignore[no-untyped-def]
    """``n`` state sequences of the soft policy (T x S x A) from the start distribution."""
    P = [T.toarray() for T in mdp.transitions]
    demos = []
    for _ in range(n):
        s = rng.choice(mdp.num_states, p=start)
        path = [s]
        for t in range(HORIZON):
            a = rng.choice(mdp.num_actions, p=policy.policy[t, s])
            s = rng.choice(mdp.num_states, p=P[a][s])
            path.append(s)
        demos.append(np.array(path))
    return demos


def main() -> None:
    args = parse(__doc__ or "")
    mdp, cells = grid_world(LAYOUT, gamma=1.0, slip=0.1)
    pos = np.array(list(cells.keys()), dtype=float)
    centers = np.array([[0.0, 5.0], [5.0, 5.0], [5.0, 0.0], [2.0, 2.0]])
    Phi = np.exp(-0.5 * ((pos[:, None, :] - centers[None]) ** 2).sum(axis=2) / 1.5**2)
    w_true = np.array([1.0, 2.0, -1.0, -1.5])
    beta = 2.0
    start = np.full(mdp.num_states, 1.0 / mdp.num_states)  # episodes start anywhere
    expert = soft_value_iteration(mdp, Phi @ (beta * w_true), HORIZON)
    rng = np.random.default_rng(0)
    demos = sample(mdp, expert, start, 300 if fast() else 2000, rng)
    muE = demonstration_feature_counts(demos, Phi)
    res = max_entropy_irl(mdp, Phi, muE, start, HORIZON)
    w = res.weights
    cosine = float(w @ w_true / np.linalg.norm(w) / np.linalg.norm(w_true))
    print(
        f"{len(demos)} demonstrations; learned weights {np.round(w, 3)} vs beta w "
        f"{beta * w_true}; cosine {cosine:.4f}; feature-count mismatch {res.mismatch:.2e} "
        f"after {res.iterations} L-BFGS iterations"
    )

    def image(values: np.ndarray) -> np.ndarray:
        out = np.full((len(LAYOUT), len(LAYOUT[0])), np.nan)
        for (r, c), s in cells.items():
            out[r, c] = values[s]
        return out

    learned = soft_value_iteration(mdp, Phi @ w, HORIZON)
    visits_expert = np.zeros(mdp.num_states)
    for d in demos:
        np.add.at(visits_expert, d[1:], 1.0 / len(demos))
    visits_learned = expected_feature_counts(mdp, learned, np.eye(mdp.num_states), start)
    panels = [
        ("true reward w^T phi / |w|", Phi @ w_true / np.linalg.norm(w_true)),
        ("recovered reward / |w|", Phi @ w / np.linalg.norm(w)),
        ("expert visits (demonstrations)", visits_expert),
        ("visits of the learned soft policy", visits_learned),
    ]
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.6))
    for ax, (title, values) in zip(axes, panels):
        im = ax.imshow(image(values), cmap="viridis")
        fig.colorbar(im, ax=ax, shrink=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"Maximum-entropy IRL on a grid world: cosine(w, w_true) = {cosine:.4f}")
    fig.tight_layout()
    finish({"grid_world_max_entropy_irl": fig}, args.save)


if __name__ == "__main__":
    main()
