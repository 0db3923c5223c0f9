"""Lyapunov equations with a non-symmetric right-hand side (audit, session 31).

``solve_lyapunov`` and ``solve_discrete_lyapunov`` document ``Q`` as "usually symmetric" and
return ``P`` "symmetric when ``Q`` is": a non-symmetric ``Q`` is allowed. Both symmetrized every
solution, so for such ``Q`` they returned the solution for ``(Q + Q^T) / 2`` (residual ~1).
Reference: SciPy's ``solve_continuous_lyapunov`` / ``solve_discrete_lyapunov`` and the residual.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control import solve_discrete_lyapunov, solve_lyapunov


def _system(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) - 3.0 * np.eye(n)
    return A, rng.standard_normal((n, n))


@pytest.mark.parametrize("n", [2, 3, 5])
@pytest.mark.parametrize("seed", [0, 1])
def test_continuous_non_symmetric_q(n: int, seed: int) -> None:
    A, Q = _system(n, seed)
    P = solve_lyapunov(A, Q)
    np.testing.assert_allclose(A.T @ P + P @ A + Q, 0.0, atol=1e-10)
    np.testing.assert_allclose(P, sla.solve_continuous_lyapunov(A.T, -Q), atol=1e-10)


@pytest.mark.parametrize("n", [2, 3, 5])
@pytest.mark.parametrize("seed", [0, 1])
def test_discrete_non_symmetric_q(n: int, seed: int) -> None:
    A, Q = _system(n, seed)
    A = A / (1.5 * np.max(np.abs(np.linalg.eigvals(A))))
    P = solve_discrete_lyapunov(A, Q)
    np.testing.assert_allclose(A.T @ P @ A - P + Q, 0.0, atol=1e-10)
    np.testing.assert_allclose(P, sla.solve_discrete_lyapunov(A.T, Q), atol=1e-10)


@pytest.mark.parametrize("solve", [solve_lyapunov, solve_discrete_lyapunov])
def test_symmetric_q_still_gives_exactly_symmetric_p(solve: object) -> None:
    A, Q = _system(4, 2)
    A = A / (1.5 * np.max(np.abs(np.linalg.eigvals(A))))
    P = solve(A, Q @ Q.T)  # type: ignore[operator]
    assert np.array_equal(P, P.T)
