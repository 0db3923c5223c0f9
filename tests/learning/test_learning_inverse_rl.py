from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import apprenticeship_learning, feature_expectations
from taskspace.optimal_control import grid_world, make_mdp, value_iteration


def _problem(seed: int):  # type: ignore[no-untyped-def]
    mdp, _ = grid_world(["....", "..#.", "...."], gamma=0.9, slip=0.1)
    rng = np.random.default_rng(seed)
    S = mdp.num_states
    Phi = rng.uniform(size=(S, 4))
    w = rng.normal(size=4)
    w /= np.linalg.norm(w)
    d0 = np.full(S, 1.0 / S)
    expert = value_iteration(make_mdp(mdp.transitions, Phi @ w, mdp.gamma)).policy
    return mdp, Phi, w, d0, expert


def test_feature_expectations_closed_form() -> None:
    mdp, Phi, _, d0, expert = _problem(0)
    P, _ = mdp.policy_matrix(expert)
    ref = d0 @ np.linalg.solve(np.eye(mdp.num_states) - mdp.gamma * P.toarray(), Phi)
    assert feature_expectations(mdp, expert, Phi, d0) == pytest.approx(ref)


@pytest.mark.parametrize("seed", [0, 2, 3])
def test_apprenticeship_learning_matches_the_expert(seed: int) -> None:
    mdp, Phi, w_true, d0, expert = _problem(seed)
    muE = feature_expectations(mdp, expert, Phi, d0)
    res = apprenticeship_learning(mdp, Phi, muE, d0, tolerance=1e-3)
    assert res.success and res.margin <= 1e-3
    assert np.linalg.norm(res.mixture_point - muE) <= 1e-3
    # The mixture's value under the (unknown) true reward is the expert's within the margin;
    # the best policy found is at least as good as the expert up to that margin.
    best = max(float(w_true @ mu) for mu in res.feature_expectations)
    assert best >= float(w_true @ muE) - 1e-3
    # The first policy (all "up") is far from the expert: the algorithm had work to do.
    assert res.margins[0] > 0.1


def test_slow_case_mixture_point_is_a_mixture_of_the_policies() -> None:
    # Seed 1: the projection algorithm approaches mu_E slowly (the expert is not found by a
    # greedy step); mu_bar must still be a convex combination of the policies found.
    import scipy.optimize

    mdp, Phi, w_true, d0, expert = _problem(1)
    muE = feature_expectations(mdp, expert, Phi, d0)
    res = apprenticeship_learning(mdp, Phi, muE, d0, tolerance=1e-3, max_iterations=30)
    assert res.margins[-1] < 0.1 * res.margins[0]
    M = np.vstack([np.array(res.feature_expectations).T, np.ones(len(res.feature_expectations))])
    lam, resid = scipy.optimize.nnls(M, np.append(res.mixture_point, 1.0))
    assert resid < 1e-8
    # Its value under any unit reward is within the margin of the expert's (Cauchy-Schwarz).
    assert abs(float(w_true @ (M[:-1] @ lam - muE))) <= res.margin + 1e-9


def test_errors() -> None:
    mdp, Phi, _, d0, _ = _problem(0)
    with pytest.raises(InvalidInputError, match="entries"):
        apprenticeship_learning(mdp, Phi, np.zeros(3), d0)
    with pytest.raises(InvalidInputError, match="features"):
        feature_expectations(mdp, np.zeros(mdp.num_states, dtype=int), Phi[:3], d0)
