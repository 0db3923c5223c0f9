"""Riccati solvers on ill-scaled problems (#15): symplectic balancing and Newton refinement.

References independent of our solvers: the closed-form CARE of the double integrator, a
50-digit Newton-Hewer DARE (decimal arithmetic, tests/control/_decimal_riccati.py), and
scipy's solve_continuous_are / solve_discrete_are on the well-scaled problem carried to the
ill-scaled one by the exact change of state units ``x' = T x`` (``P' = T^-1 P T^-1``).
Before: Q = 1e-15 I, R = 1 on the double integrator gave P 14 % off (1e-12: 2e-4) with
SUCCESS; state units spread over 1e-6..1e6 gave P up to 140 % (CARE) and 3000 % (DARE) off
without an error; the DARE had no refinement (Q = 1e14 I: 3e-5 off).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control import dlqr, lqr
from taskspace.control.riccati import solve_continuous_riccati, solve_discrete_riccati
from taskspace.errors import SolverError
from tests.control._decimal_riccati import dare_reference

A_DI = np.array([[0.0, 1.0], [0.0, 0.0]])
B_DI = np.array([[0.0], [1.0]])
DT = 0.1
A_DD = np.array([[1.0, DT], [0.0, 1.0]])
B_DD = np.array([[DT**2 / 2], [DT]])


def _entrywise(P: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(P - ref) / np.abs(ref)))


@pytest.mark.parametrize("q", [1e-15, 1e-12, 1e-9, 1e-6, 1.0, 1e6, 1e9, 1e12, 1e14])
def test_care_double_integrator_closed_form(q: float) -> None:
    p12 = np.sqrt(q)
    p22 = np.sqrt(q + 2 * p12)
    ref = np.array([[p12 * p22, p12], [p12, p22]])
    res = solve_continuous_riccati(A_DI, B_DI, q * np.eye(2), 1.0)
    assert res.success
    assert _entrywise(res.P, ref) < 1e-12
    K = lqr(A_DI, B_DI, q * np.eye(2), 1.0).K
    np.testing.assert_allclose(K, ref[1:, :], rtol=1e-12)  # K = R^-1 B^T P


@pytest.mark.parametrize("q", [1e-15, 1e-12, 1e-9, 1.0, 1e9, 1e12, 1e14])
def test_dare_discrete_double_integrator_against_50_digits(q: float) -> None:
    Q, R = q * np.eye(2), np.eye(1)
    ref = dare_reference(A_DD, B_DD, Q, R, sla.solve_discrete_are(A_DD, B_DD, Q, R))
    res = solve_discrete_riccati(A_DD, B_DD, Q, R)
    assert res.success
    assert _entrywise(res.P, ref) < 1e-9  # old: SolverError, 3e-9, 4e-11, ..., 8e-7, 3e-5
    K_ref = np.linalg.solve(R + B_DD.T @ ref @ B_DD, B_DD.T @ ref @ A_DD)
    np.testing.assert_allclose(dlqr(A_DD, B_DD, Q, R).K, K_ref, rtol=1e-9)


@pytest.mark.parametrize("discrete", [False, True])
@pytest.mark.parametrize("seed", range(8))
def test_state_units_spread_over_twelve_decades(seed: int, discrete: bool) -> None:
    rng = np.random.default_rng(seed)
    n, m = 4, 2
    A, B = rng.normal(size=(n, n)), rng.normal(size=(n, m))
    if discrete:
        A, B = sla.expm(0.1 * A), 0.1 * B
    Q, R = np.eye(n), np.eye(m)
    P = (sla.solve_discrete_are if discrete else sla.solve_continuous_are)(A, B, Q, R)
    t = 10.0 ** rng.uniform(-6, 6, n)
    T, Ti = np.diag(t), np.diag(1 / t)
    Q2 = Ti @ Q @ Ti
    solve = solve_discrete_riccati if discrete else solve_continuous_riccati
    res = solve(T @ A @ Ti, T @ B, 0.5 * (Q2 + Q2.T), R)
    assert res.success
    back = T @ res.P @ T  # in the well-scaled units
    assert np.max(np.abs(back - P)) < 1e-9 * np.max(np.abs(P))


@pytest.mark.parametrize("q", [1e300, 1e307])
def test_an_inaccurate_solution_is_refused(q: float) -> None:
    # the Hamiltonian spans 600 decades: the balanced Schur solution was 1e44 times off
    # (closed form: p12 = sqrt(2 q), p22 = sqrt(2 q + 2 p12), p11 = p12 p22 - q)
    Q = q * np.array([[2.0, 1.0], [1.0, 2.0]])
    p12 = np.sqrt(2 * q)
    p22 = np.sqrt(2 * q + 2 * p12)
    ref = np.array([[p12 * p22 - q, p12], [p12, p22]])
    try:
        P = solve_continuous_riccati(A_DI, B_DI, Q, 1.0).P
    except SolverError as exc:
        assert "rescale" in str(exc)
    else:
        np.testing.assert_allclose(P, ref, rtol=1e-9)
