"""Maximum-entropy IRL helpers on mismatched or foreign inputs (audit, session 31).

``expected_feature_counts`` with a soft policy of a 3-action MDP on a 2-action MDP silently
dropped the third action's probability (counts of a distribution that no longer sums to 1);
the opposite mismatch, another state count or a bare array were IndexError / ValueError /
AttributeError. ``demonstration_feature_counts`` returned NaN counts for NaN features;
``soft_value_iteration`` cut complex rewards to their real part (a ComplexWarning) and text was
a bare ValueError. Valid inputs are checked against a forward pass written here in NumPy.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import (
    SoftPolicy,
    demonstration_feature_counts,
    expected_feature_counts,
    soft_value_iteration,
)
from taskspace.optimal_control import make_mdp


def _mdps() -> tuple[object, object, object, np.ndarray]:
    rng = np.random.default_rng(0)
    P = rng.random((3, 4, 4))
    P /= P.sum(axis=2, keepdims=True)
    R = np.zeros((4, 3))
    m2 = make_mdp(P[:2], R[:, :2], 0.9)
    m3 = make_mdp(P, R, 0.9)
    m5 = make_mdp(np.full((2, 5, 5), 0.2), np.zeros((5, 2)), 0.9)
    return m2, m3, m5, P


def test_counts_match_numpy_forward_pass() -> None:
    m2, _, _, P = _mdps()
    r = np.array([0.3, -1.0, 2.0, 0.5])
    pol = soft_value_iteration(m2, r, 3)  # type: ignore[arg-type]
    d0 = np.full(4, 0.25)
    D, ref = d0.copy(), np.zeros(4)
    for t in range(3):
        D = sum((D * pol.policy[t, :, a]) @ P[a] for a in range(2))
        ref += D
    np.testing.assert_allclose(
        expected_feature_counts(m2, pol, np.eye(4), d0),  # type: ignore[arg-type]
        ref,
        atol=1e-14,
    )


def test_policy_of_another_mdp_is_refused() -> None:
    m2, m3, m5, _ = _mdps()
    r = np.zeros(4)
    pol3 = soft_value_iteration(m3, r, 2)  # type: ignore[arg-type]
    pol2 = soft_value_iteration(m2, r, 2)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="policy"):
        expected_feature_counts(m2, pol3, np.eye(4), np.full(4, 0.25))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="policy"):
        expected_feature_counts(m3, pol2, np.eye(4), np.full(4, 0.25))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="policy"):
        expected_feature_counts(m5, pol2, np.eye(5), np.full(5, 0.2))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="SoftPolicy"):
        expected_feature_counts(m2, pol2.policy, np.eye(4), np.full(4, 0.25))  # type: ignore[arg-type]
    bad = SoftPolicy(V=pol2.V, policy=np.full_like(pol2.policy, np.nan))
    with pytest.raises(InvalidInputError, match="policy"):
        expected_feature_counts(m2, bad, np.eye(4), np.full(4, 0.25))  # type: ignore[arg-type]


def test_demonstration_counts_refuse_non_finite_features() -> None:
    Phi = np.eye(4)
    np.testing.assert_array_equal(demonstration_feature_counts([[0, 1, 2]], Phi), [0, 1, 1, 0])
    Phi[1, 1] = np.nan
    with pytest.raises(InvalidInputError, match="features"):
        demonstration_feature_counts([[0, 1, 2]], Phi)


@pytest.mark.parametrize(
    "rewards", [np.array([1.0, 0.0, 0.0, 1j]), "abcd"], ids=["complex", "text"]
)
def test_soft_value_iteration_refuses_non_real_rewards(rewards: object) -> None:
    m2, _, _, _ = _mdps()
    with pytest.raises(InvalidInputError, match="reward"):
        soft_value_iteration(m2, rewards, 2)  # type: ignore[arg-type]
