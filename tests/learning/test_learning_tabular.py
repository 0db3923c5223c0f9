from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import MDPSimulator, TabularOptions, q_learning, sarsa, td_lambda
from taskspace.optimal_control import evaluate_policy, grid_world, t_maze, value_iteration

LAYOUT = ["...G", ".#.X", "S..."]


def test_q_learning_t_maze_exact() -> None:
    # Deterministic MDP, alpha = 1: Q-learning is asynchronous value iteration.
    mdp = t_maze(gamma=0.5)
    exact = value_iteration(mdp)
    res = q_learning(
        mdp,
        TabularOptions(episodes=300, max_steps=20, learning_rate_decay=0.0, epsilon=1.0),
        rng=np.random.default_rng(0),
    )
    assert res.Q == pytest.approx(exact.Q, abs=1e-12)
    assert np.array_equal(res.policy[:3], exact.policy[:3])


def test_sarsa_with_decaying_exploration_reaches_the_optimum() -> None:
    mdp = t_maze(gamma=0.5)
    exact = value_iteration(mdp)
    res = sarsa(
        mdp,
        TabularOptions(episodes=2000, max_steps=20, epsilon=0.5, epsilon_decay=0.05),
        rng=np.random.default_rng(0),
    )
    assert res.V == pytest.approx(exact.V, abs=0.02)


def test_q_learning_slippery_grid_world() -> None:
    mdp, _ = grid_world(LAYOUT, gamma=0.9, slip=0.2)
    exact = value_iteration(mdp)
    res = q_learning(
        mdp, TabularOptions(episodes=1500, max_steps=50, epsilon=1.0), rng=np.random.default_rng(0)
    )
    assert np.abs(res.V - exact.V).max() < 0.05
    assert np.abs(res.Q - exact.Q).max() < 0.06


@pytest.mark.parametrize("lam", [0.0, 0.6, 1.0])
def test_td_lambda_converges_to_the_policy_value(lam: float) -> None:
    mdp, _ = grid_world(LAYOUT, gamma=0.9, slip=0.2)
    policy = value_iteration(mdp).policy
    exact = evaluate_policy(mdp, policy)
    res = td_lambda(
        mdp,
        policy,
        TabularOptions(episodes=1500, max_steps=50, trace_decay=lam),
        rng=np.random.default_rng(1),
    )
    assert np.abs(res.V - exact).max() < 0.04  # lambda = 1 is Monte Carlo: most variance
    # A uniformly random policy has a different value (the test can fail).
    uniform = np.full((mdp.num_states, mdp.num_actions), 0.25)
    assert (
        np.abs(
            res.V
            - td_lambda(
                mdp,
                uniform,
                TabularOptions(episodes=300, max_steps=50),
                rng=np.random.default_rng(2),
            ).V
        ).max()
        > 0.1
    )


def test_simulator_samples_the_transition_probabilities() -> None:
    mdp, cells = grid_world(LAYOUT, gamma=0.9, slip=0.4)
    sim = MDPSimulator(mdp, np.random.default_rng(0))
    s = cells[(2, 1)]
    counts = np.bincount([sim.step(s, 0)[0] for _ in range(4000)], minlength=mdp.num_states)
    expected = mdp.transitions[0][s].toarray().ravel()
    assert counts / 4000 == pytest.approx(expected, abs=0.03)
    assert sim.absorbing[cells[(0, 3)]] and not sim.absorbing[s]


def test_errors() -> None:
    mdp = t_maze()
    rng = np.random.default_rng(0)
    with pytest.raises(InvalidInputError, match="epsilon"):
        q_learning(mdp, TabularOptions(epsilon=2.0), rng=rng)
    with pytest.raises(InvalidInputError, match="lambda"):
        td_lambda(
            mdp, np.zeros(mdp.num_states, dtype=int), TabularOptions(trace_decay=1.5), rng=rng
        )
    with pytest.raises(InvalidInputError, match="shape"):
        td_lambda(mdp, [0, 1], rng=rng)
    with pytest.raises(InvalidInputError, match="start_states"):
        sarsa(mdp, TabularOptions(start_states=(99,)), rng=rng)
