"""``feature_expectations`` / ``apprenticeship_learning`` start distributions (audit, session 31).

``start`` is documented as the initial state distribution; a NaN entry gave NaN feature
expectations, a vector of ones (sum 4) four times the true ones, and zero feature columns a
bare ``ValueError: need at least one array to stack``. Valid inputs match
``d0^T (I - gamma P_pi)^-1 Phi`` solved densely with NumPy.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import apprenticeship_learning, feature_expectations
from taskspace.optimal_control import make_mdp


def _mdp() -> tuple[object, np.ndarray]:
    rng = np.random.default_rng(0)
    P = rng.random((2, 4, 4))
    P /= P.sum(axis=2, keepdims=True)
    return make_mdp(P, np.zeros((4, 2)), 0.9), P


def test_matches_dense_solve() -> None:
    mdp, P = _mdp()
    policy = [0, 1, 0, 1]
    Phi = np.arange(8.0).reshape(4, 2)
    d0 = np.array([0.1, 0.2, 0.3, 0.4])
    Ppi = P[policy, np.arange(4)]
    ref = d0 @ np.linalg.solve(np.eye(4) - 0.9 * Ppi, Phi)
    np.testing.assert_allclose(feature_expectations(mdp, policy, Phi, d0), ref, rtol=1e-12)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "start",
    [[np.nan, 0.5, 0.5, 0.0], [1.0, 1.0, 1.0, 1.0], [1.5, -0.5, 0.0, 0.0], [np.inf, 0, 0, 0]],
    ids=["nan", "sum4", "negative", "inf"],
)
def test_start_must_be_a_distribution(start: list[float]) -> None:
    mdp, _ = _mdp()
    with pytest.raises(InvalidInputError, match="start"):
        feature_expectations(mdp, [0, 1, 0, 1], np.eye(4), start)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="start"):
        apprenticeship_learning(mdp, np.eye(4), np.full(4, 2.5), start)  # type: ignore[arg-type]


def test_features_need_a_column_and_finite_values() -> None:
    mdp, _ = _mdp()
    with pytest.raises(InvalidInputError, match="features"):
        feature_expectations(mdp, [0, 1, 0, 1], np.zeros((4, 0)), np.full(4, 0.25))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="features"):
        feature_expectations(mdp, [0, 1, 0, 1], np.full((4, 2), np.nan), np.full(4, 0.25))  # type: ignore[arg-type]
