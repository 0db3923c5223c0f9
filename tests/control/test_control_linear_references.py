"""Linear control theory against independent references (issue #15).

* single-input pole placement: the gain is unique, so Ackermann's formula and our robust
  method must equal ``scipy.signal.place_poles``;
* controllability / observability: for a stable ``A`` the Gramians (scipy's Lyapunov solver)
  are nonsingular exactly when the pair is controllable / observable, and the uncontrollable
  part built by a similarity transform is found.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal

from taskspace.control import acker, controllability, observability, place


@pytest.mark.parametrize("seed", range(6))
def test_single_input_gain_matches_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 2 + seed % 4
    A = rng.standard_normal((n, n))
    B = rng.standard_normal((n, 1))
    poles = -np.arange(1.0, n + 1.0)
    ref = scipy.signal.place_poles(A, B, poles).gain_matrix
    np.testing.assert_allclose(acker(A, B, poles), ref, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(place(A, B, poles), ref, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("seed", range(6))
def test_gramian_rank_agrees_with_the_rank_tests(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    n, m = 4, 1
    # a stable A with a block that B cannot reach (and C cannot see) when seed is odd
    A = rng.standard_normal((n, n)) - 6.0 * np.eye(n)
    B = rng.standard_normal((n, m))
    C = rng.standard_normal((m, n))
    if seed % 2:
        A[2:, :2] = 0.0  # x_34' does not depend on x_12
        B[2:] = 0.0  # and receives no input: x_34 uncontrollable
        C[:, :2] = 0.0
        A[:2, 2:] = 0.0  # decoupled: x_12 unobservable through C = [0, 0, c3, c4]
    T = sla.qr(rng.standard_normal((n, n)))[0]  # hide the structure
    A, B, C = T @ A @ T.T, T @ B, C @ T.T
    Wc = sla.solve_continuous_lyapunov(A, -B @ B.T)
    Wo = sla.solve_continuous_lyapunov(A.T, -C.T @ C)
    expect_c = np.linalg.matrix_rank(Wc, tol=1e-9 * np.abs(Wc).max()) == n
    expect_o = np.linalg.matrix_rank(Wo, tol=1e-9 * np.abs(Wo).max()) == n
    assert controllability(A, B).controllable == expect_c == (seed % 2 == 0)
    assert observability(A, C).observable == expect_o == (seed % 2 == 0)
    if seed % 2:
        assert controllability(A, B).uncontrollable_modes.size == 2
