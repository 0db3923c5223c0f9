"""make_mdp with low-precision transition matrices (audit3, left open): rows normalised in
float32 (or float16) sum to 1 only within the dtype's rounding, which the fixed 1e-9 row-sum
tolerance refused. The allowed deviation of a row now scales with its dtype's eps and its
number of nonzeros; a row that really does not sum to 1 is still refused.

Reference: the Bellman optimality equation evaluated densely with numpy on the float64 copy of
the float32 matrices (``V = max_a R_a + gamma P_a V``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from taskspace.errors import InvalidInputError
from taskspace.optimal_control.dynamic_programming import ValueIterationOptions, value_iteration
from taskspace.optimal_control.mdp import make_mdp


def stochastic(rng: np.random.Generator, S: int, dtype: type) -> np.ndarray:
    x = rng.exponential(size=(S, S)).astype(dtype)
    return x / x.sum(axis=1, keepdims=True)  # normalised in the low precision


def test_float32_rows_are_accepted_and_solved() -> None:
    rng = np.random.default_rng(0)
    S, A = 200, 3
    Ps = [stochastic(rng, S, np.float32) for _ in range(A)]
    assert max(abs(P.astype(np.float64).sum(axis=1) - 1).max() for P in Ps) > 1e-9
    R = rng.normal(size=(S, A))
    mdp = make_mdp(Ps, R, 0.9)
    for P, Pm in zip(Ps, mdp.transitions):
        np.testing.assert_array_equal(Pm.toarray(), P.astype(np.float64))  # stored as given
    V = value_iteration(mdp, ValueIterationOptions(tolerance=1e-12)).V
    Q = R + 0.9 * np.stack([P.astype(np.float64) @ V for P in Ps], axis=1)
    np.testing.assert_allclose(V, Q.max(axis=1), atol=1e-9)
    # the A x S x S array, sparse float32 and float16 rows are accepted too
    make_mdp(np.stack(Ps), R, 0.9)
    make_mdp([sp.csr_matrix(P) for P in Ps], R, 0.9)
    make_mdp([stochastic(rng, 3, np.float16)], np.zeros(3), 0.9)


@pytest.mark.parametrize("dtype", [np.float32, np.float16])
def test_low_precision_non_stochastic_row_is_refused(dtype: type) -> None:
    P = np.eye(4, dtype=dtype)
    P[2] = np.array([0.5, 0.49, 0.0, 0.0], dtype=dtype)  # sums to 0.99
    both = [[P]] if dtype == np.float16 else [[P], [sp.csr_matrix(P)]]  # no sparse float16
    for transitions in both:
        with pytest.raises(InvalidInputError, match=r"rows \[2\].*not 1.*tolerance"):
            make_mdp(transitions, np.zeros(4), 0.9)


def test_float64_tolerance_is_unchanged() -> None:
    P = np.eye(3)
    P[1] = [0.5, 0.5 + 1e-7, 0.0]
    with pytest.raises(InvalidInputError, match=r"rows \[1\]"):
        make_mdp([P], np.zeros(3), 0.9)
    # in float32 the same row is within its rounding: 2 nonzeros x eps 1.19e-7
    make_mdp([P.astype(np.float32)], np.zeros(3), 0.9)
