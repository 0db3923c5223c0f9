from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.special

from taskspace.errors import InvalidInputError
from taskspace.learning import (
    MaxEntIRLOptions,
    demonstration_feature_counts,
    expected_feature_counts,
    max_entropy_irl,
    soft_value_iteration,
)
from taskspace.optimal_control import grid_world

HORIZON = 5


def _problem(slip: float = 0.0):  # type: ignore[no-untyped-def]
    mdp, _ = grid_world(["...", ".#.", "..."], gamma=1.0, slip=slip)
    rng = np.random.default_rng(3)
    Phi = rng.uniform(size=(mdp.num_states, 3))
    w = np.array([1.0, -2.0, 0.5])
    d0 = np.zeros(mdp.num_states)
    d0[[0, 4]] = 0.5
    return mdp, Phi, w, d0


def _enumerate(mdp, Phi, w, d0):  # type: ignore[no-untyped-def]
    """Maximum-entropy distribution over all action sequences, by enumeration."""
    succ = np.stack([P.toarray().argmax(axis=1) for P in mdp.transitions], axis=1)
    mu = np.zeros(Phi.shape[1])
    logZ = np.zeros(mdp.num_states)
    paths = {}
    for s0 in np.flatnonzero(d0 > 0):
        seqs, counts = [], []
        for actions in itertools.product(range(mdp.num_actions), repeat=HORIZON):
            s, path = s0, [s0]
            for a in actions:
                s = succ[s, a]
                path.append(s)
            seqs.append(path)
            counts.append(Phi[path[1:]].sum(axis=0))
        F = np.array(counts)
        logZ[s0] = scipy.special.logsumexp(F @ w)
        p = np.exp(F @ w - logZ[s0])
        mu += d0[s0] * p @ F
        paths[s0] = (np.array(seqs), p)
    return mu, logZ, paths


def test_soft_policy_matches_enumeration_of_all_action_sequences() -> None:
    mdp, Phi, w, d0 = _problem()
    soft = soft_value_iteration(mdp, Phi @ w, HORIZON)
    mu_enum, logZ, _ = _enumerate(mdp, Phi, w, d0)
    assert expected_feature_counts(mdp, soft, Phi, d0) == pytest.approx(mu_enum, rel=1e-12)
    starts = d0 > 0
    assert soft.V[0][starts] == pytest.approx(logZ[starts], rel=1e-12)
    assert soft.policy.sum(axis=2) == pytest.approx(np.ones(soft.policy.shape[:2]))


@pytest.mark.parametrize("beta", [0.5, 3.0])
def test_recovers_the_weights_from_exact_feature_counts(beta: float) -> None:
    # An expert soft-optimal for beta w (temperature 1 / beta): the weights come back as
    # beta w, i.e. w up to the scale the demonstrations cannot tell.
    mdp, Phi, w, d0 = _problem()
    muE, _, _ = _enumerate(mdp, Phi, beta * w, d0)
    res = max_entropy_irl(mdp, Phi, muE, d0, HORIZON, MaxEntIRLOptions(tolerance=1e-9))
    assert res.success, res.message
    assert res.weights == pytest.approx(beta * w, rel=1e-6, abs=1e-6)
    assert res.feature_counts == pytest.approx(muE, abs=1e-9)


def test_recovers_the_direction_from_sampled_demonstrations() -> None:
    mdp, Phi, w, d0 = _problem()
    _, _, paths = _enumerate(mdp, Phi, 2.0 * w, d0)
    rng = np.random.default_rng(0)
    demos = []
    for _ in range(3000):
        s0 = rng.choice(mdp.num_states, p=d0)
        seqs, p = paths[s0]
        demos.append(seqs[rng.choice(len(p), p=p)])
    muE = demonstration_feature_counts(demos, Phi)
    res = max_entropy_irl(mdp, Phi, muE, d0, HORIZON)
    assert res.success
    cosine = res.weights @ w / np.linalg.norm(res.weights) / np.linalg.norm(w)
    assert cosine > 0.99


def test_stochastic_transitions_dual_gradient_and_recovery() -> None:
    mdp, Phi, w, d0 = _problem(slip=0.2)
    muE = expected_feature_counts(mdp, soft_value_iteration(mdp, Phi @ w, HORIZON), Phi, d0)

    def dual(v):  # type: ignore[no-untyped-def]
        return d0 @ soft_value_iteration(mdp, Phi @ v, HORIZON).V[0] - v @ muE

    v = np.array([0.3, 0.1, -0.7])
    grad = expected_feature_counts(mdp, soft_value_iteration(mdp, Phi @ v, HORIZON), Phi, d0) - muE
    h = 1e-6
    fd = [(dual(v + h * e) - dual(v - h * e)) / (2 * h) for e in np.eye(3)]
    assert grad == pytest.approx(fd, abs=1e-7)
    res = max_entropy_irl(mdp, Phi, muE, d0, HORIZON, MaxEntIRLOptions(tolerance=1e-9))
    assert res.success
    assert res.weights == pytest.approx(w, rel=1e-5, abs=1e-5)


def test_errors() -> None:
    mdp, Phi, _, d0 = _problem()
    with pytest.raises(InvalidInputError, match="probability distribution"):
        max_entropy_irl(mdp, Phi, np.zeros(3), np.ones(mdp.num_states), HORIZON)
    with pytest.raises(InvalidInputError, match="horizon"):
        max_entropy_irl(mdp, Phi, np.zeros(3), d0, 0)
    with pytest.raises(InvalidInputError, match="3 entries"):
        max_entropy_irl(mdp, Phi, np.zeros(2), d0, HORIZON)
    with pytest.raises(InvalidInputError, match="features"):
        max_entropy_irl(mdp, Phi[:3], np.zeros(3), d0, HORIZON)
    for bad in (0, 2.5, None):
        with pytest.raises(InvalidInputError, match="max_iterations"):
            max_entropy_irl(
                mdp, Phi, np.zeros(3), d0, HORIZON, MaxEntIRLOptions(max_iterations=bad)
            )
    with pytest.raises(InvalidInputError, match="integer state"):
        demonstration_feature_counts([[0.5, 1.0]], Phi)
    with pytest.raises(InvalidInputError, match="outside"):
        demonstration_feature_counts([[0, 99]], Phi)
