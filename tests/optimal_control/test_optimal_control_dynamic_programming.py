from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from taskspace.errors import InvalidInputError, SolverError
from taskspace.optimal_control import (
    DPStatus,
    ValueIterationOptions,
    deterministic_mdp,
    evaluate_policy,
    finite_horizon_value_iteration,
    grid_world,
    make_mdp,
    policy_iteration,
    t_maze,
    value_iteration,
)


def test_two_state_closed_form() -> None:
    # State 0: "stay" pays 1 forever, "go" pays 2 and moves to the absorbing state 1 (reward 0).
    # V(0) = max(1 / (1 - gamma), 2) -> 1/(1-gamma) for gamma > 1/2, else 2.
    for gamma, expected in [(0.9, 10.0), (0.3, 2.0)]:
        mdp = deterministic_mdp([[0, 1], [1, 1]], [[1.0, 2.0], [0.0, 0.0]], gamma)
        for solve in (value_iteration, policy_iteration):
            res = solve(mdp)
            assert res.success and res.status is DPStatus.CONVERGED
            assert res.V == pytest.approx([expected, 0.0], abs=1e-8)
            assert res.policy[0] == (0 if gamma > 0.5 else 1)


def test_random_mdp_against_enumeration_of_policies() -> None:
    # Exact optimum: the best of all |A|^|S| deterministic policies, evaluated by a dense solve.
    rng = np.random.default_rng(0)
    S, A, gamma = 4, 3, 0.8
    P = rng.uniform(size=(A, S, S)) * (rng.uniform(size=(A, S, S)) < 0.6)
    P[:, np.arange(S), np.arange(S)] += 0.1
    P /= P.sum(axis=2, keepdims=True)
    R = rng.normal(size=(S, A))
    mdp = make_mdp([sp.csr_matrix(p) for p in P], R, gamma)
    best = np.full(S, -np.inf)
    for pi in itertools.product(range(A), repeat=S):
        Ppi = P[list(pi), np.arange(S)]
        V = np.linalg.solve(np.eye(S) - gamma * Ppi, R[np.arange(S), list(pi)])
        best = np.maximum(best, V)
    vi = value_iteration(mdp, ValueIterationOptions(tolerance=1e-12))
    pi_res = policy_iteration(mdp)
    assert vi.V == pytest.approx(best, abs=1e-9)
    assert pi_res.V == pytest.approx(best, abs=1e-9)
    assert np.array_equal(vi.policy, pi_res.policy)
    assert evaluate_policy(mdp, pi_res.policy) == pytest.approx(best, abs=1e-9)
    assert vi.residual < 1e-9


def test_t_maze_gamma_half() -> None:
    # Stem of 3 cells, left arm: 1 cell with reward 1, right arm: 2 cells with reward 3.
    # Junction: left pays 1 now, right pays 3 one step later: max(1, 0.5 * 3) = 1.5 (go right).
    # Stem: V(stem1) = 0.5 * 1.5 = 0.75, V(stem0) = 0.375; right1: 3.
    mdp = t_maze(gamma=0.5)
    res = value_iteration(mdp)
    V = dict(zip(mdp.state_names, res.V))
    assert V["stem2"] == pytest.approx(1.5)
    assert V["stem1"] == pytest.approx(0.75)
    assert V["stem0"] == pytest.approx(0.375)
    assert V["right1"] == pytest.approx(3.0)
    assert V["left1"] == pytest.approx(0.0)
    assert mdp.action_names[res.policy[mdp.state_names.index("stem2")]] == "right"
    # With gamma = 0.2 the far reward is worth 0.6 < 1: go left.
    res2 = value_iteration(t_maze(gamma=0.2))
    assert res2.V[2] == pytest.approx(1.0)
    assert res2.policy[2] == 1


def test_finite_horizon_closed_form() -> None:
    # Chain 0 -> 1 -> 2 (absorbing): reward 1 for each move; horizon T: V_0(0) = min(T, 2).
    mdp = deterministic_mdp([[1, 0], [2, 1], [2, 2]], [[1.0, 0.0], [1.0, 0.0], [0.0, 0.0]], 1.0)
    for T in (1, 2, 5):
        res = finite_horizon_value_iteration(mdp, T)
        assert res.V[0, 0] == pytest.approx(min(T, 2))
        assert res.V.shape == (T + 1, 3)
    # Discounted infinite horizon is the limit of the finite horizon.
    mdp2 = deterministic_mdp([[1, 0], [2, 1], [0, 2]], [[1.0, 0.2], [1.0, 0.0], [3.0, 0.0]], 0.9)
    fh = finite_horizon_value_iteration(mdp2, 400)
    assert fh.V[0] == pytest.approx(value_iteration(mdp2).V, abs=1e-8)


def test_grid_world_deterministic_distances() -> None:
    # Deterministic grid world with gamma: V(s) = gamma^(d(s) - 1) for the goal at distance d.
    mdp, cells = grid_world(["...G", ".#..", "S..."], gamma=0.9)
    res = value_iteration(mdp)
    goal = (0, 3)
    for (r, c), s in cells.items():
        if (r, c) == goal:
            assert res.V[s] == 0.0
            continue
        d = abs(r - goal[0]) + abs(c - goal[1])  # the wall does not lengthen any shortest path
        assert res.V[s] == pytest.approx(0.9 ** (d - 1)), (r, c)
    # Slippery version: policy iteration agrees with value iteration.
    slip, _ = grid_world(["...G", ".#.X", "S..."], gamma=0.9, slip=0.2)
    assert policy_iteration(slip).V == pytest.approx(value_iteration(slip).V, abs=1e-8)


def test_errors() -> None:
    with pytest.raises(InvalidInputError, match="sum to"):
        make_mdp([np.array([[0.5, 0.4], [0.0, 1.0]])], [0.0, 0.0], 0.9)
    with pytest.raises(InvalidInputError, match="gamma"):
        make_mdp([np.eye(2)], [0.0, 0.0], 1.5)
    with pytest.raises(InvalidInputError, match="negative"):
        make_mdp([np.array([[1.5, -0.5], [0.0, 1.0]])], [0.0, 0.0], 0.9)
    with pytest.raises(InvalidInputError, match="valid ones"):
        grid_world(["..Z"], gamma=0.9)
    with pytest.raises(InvalidInputError, match="horizon"):
        finite_horizon_value_iteration(t_maze(), 0)
    # gamma = 1 and a policy cycling with reward: singular evaluation.
    loop = deterministic_mdp([[1], [0]], [[1.0], [1.0]], 1.0)
    with pytest.raises(SolverError, match="singular"):
        evaluate_policy(loop, [0, 0])
