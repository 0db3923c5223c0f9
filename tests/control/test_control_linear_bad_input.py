"""Bad and extreme inputs to the linear control theory (issue #15): a right answer or a
TaskspaceError, never a bare exception, a NaN result or a silently wrong one.

References are independent of taskspace: scipy's Riccati solvers, closed forms, exact scaling
identities (``P(sQ, sR) = s P(Q, R)``, ``K`` unchanged).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control import (
    PolePlacementOptions,
    acker,
    controllability,
    controllability_matrix,
    dlqr,
    is_controllable,
    kalman_decomposition,
    lqr,
    lyapunov_check,
    observability,
    observer_gain,
    place,
    solve_continuous_riccati,
    solve_discrete_lyapunov,
    solve_discrete_riccati,
    solve_riccati_differential,
    solve_riccati_recursion,
)
from taskspace.control.lqr import LQROptions
from taskspace.control.riccati import RiccatiOptions
from taskspace.errors import InvalidInputError, SolverError, TaskspaceError

A = np.array([[0.0, 1.0], [0.0, 0.0]])  # double integrator
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
Q = np.eye(2)
R = np.eye(1)
NK = LQROptions(riccati=RiccatiOptions(method="newton_kleinman"))


@pytest.mark.parametrize("tolerance", [np.nan, -1.0, 1.5, "x", 1j])
def test_rank_tolerance_is_checked(tolerance: object) -> None:
    # NaN made every rank 0: the double integrator was reported uncontrollable
    with pytest.raises(InvalidInputError, match="tolerance"):
        controllability(A, B, tolerance)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="tolerance"):
        observability(A, C, tolerance)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="tolerance"):
        kalman_decomposition(A, B, C, tolerance)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="tolerance"):
        lqr(A, B, Q, R, LQROptions(controllability_tolerance=tolerance))  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", ["abc", [[1, 2], [3]], np.array([[1 + 1j, 0.0]]), None])
def test_output_matrix_must_be_real_numbers(bad: object) -> None:
    # text and ragged lists gave a bare ValueError, complex C lost its imaginary part
    for call in (
        lambda: observability(A, bad),
        lambda: kalman_decomposition(A, B, bad),
        lambda: observer_gain(A, bad, [-1.0, -2.0]),
        lambda: observer_gain(bad, C, [-1.0, -2.0]),
    ):
        with pytest.raises(InvalidInputError):
            call()


@pytest.mark.parametrize("poles", ["ab", None, ["a", "b"], [None, -1.0]])
def test_poles_must_be_numbers(poles: object) -> None:
    with pytest.raises(InvalidInputError, match="poles"):
        place(A, B, poles)


@pytest.mark.parametrize(
    "options",
    [
        PolePlacementOptions(tolerance=np.nan),
        PolePlacementOptions(tolerance=-1.0),
        PolePlacementOptions(rtol=np.nan),
        PolePlacementOptions(max_iterations=2.5),  # type: ignore[arg-type]
        PolePlacementOptions(max_iterations=0),
    ],
)
def test_pole_placement_options_are_checked(options: PolePlacementOptions) -> None:
    # tolerance=NaN switched the final pole check off (err > nan is False)
    with pytest.raises(InvalidInputError, match="PolePlacementOptions"):
        place(A, B, [-1.0, -2.0], options)


def test_acker_overflow_is_an_error_not_a_nan_gain() -> None:
    huge = np.array([[1e300, 2e300], [1e300, 1e300]])
    with pytest.raises(InvalidInputError, match="overflow"):
        acker(huge, B, [-1.0, -2.0])


def test_controllability_matrix_overflow_is_an_error() -> None:
    # powers of A beyond float64: a bare LinAlgError "SVD did not converge" before; the
    # message names the power, the norms and the scaling. controllability() tests 2^-e A
    # instead (the same rank; here 1: N is 1e-200 of A, below any float64 rank tolerance).
    A_big = 1e200 * np.eye(3) + np.diag([1.0, 2.0], 1)
    with pytest.raises(
        InvalidInputError, match=r"overflows float64.* at A\^2 B: \|A\|_2 = 1e\+200"
    ):
        controllability_matrix(A_big, np.ones((3, 1)))
    rep = controllability(A_big, np.ones((3, 1)))
    assert rep.rank == 1 and not rep.controllable
    np.testing.assert_allclose(rep.uncontrollable_modes, [1e200] * 3, rtol=1e-15)


def test_controllability_with_entries_near_1e300() -> None:
    # [B, AB] = [[0, 2e300], [1, 1e300]] has determinant -2e300: controllable. The column
    # norms overflowed to inf (the columns became 0) and a common PBH scale made B vanish.
    A_big = np.array([[1e300, 2e300], [1e300, 1e300]])
    rep = controllability(A_big, B)
    assert rep.controllable and rep.rank == 2
    assert rep.uncontrollable_modes.size == 0
    assert observability(A_big.T, B.T).observable
    # and an uncontrollable pair at the same scale is still found: B along an eigenvector
    A_diag = np.diag([1e300, 2e300])
    rep = controllability(A_diag, [[1.0], [0.0]])
    assert not rep.controllable
    np.testing.assert_allclose(rep.uncontrollable_modes.real, [2e300])
    assert is_controllable(A_diag, [[1.0], [1.0]])


@pytest.mark.parametrize("scale", [2.0**-600, 1e-200, 1e-15, 1e9, 1e15, 1e200, 1e300])
@pytest.mark.parametrize("method", ["schur", "newton_kleinman"])
def test_lqr_is_scale_invariant_in_the_cost(scale: float, method: str) -> None:
    # P(sQ, sR) = s P(Q, R), K unchanged. Before: Schur reported "no stabilizing solution"
    # (1e-200), or SOLVED with P 49 % off (1e9) / 27 % off (1e-15); Newton-Kleinman stopped at
    # its second iterate as SOLVED with P off by 27 % (1e-200).
    ref = sla.solve_continuous_are(A, B, Q, R)
    res = lqr(
        A,
        B,
        scale * Q,
        scale * R,
        LQROptions(riccati=RiccatiOptions(method=method)),
        initial_gain=[[1.0, 1.0]] if method == "newton_kleinman" else None,
    )
    assert res.success
    np.testing.assert_allclose(res.P / scale, ref, rtol=1e-10)
    np.testing.assert_allclose(res.K, R @ B.T @ ref, rtol=1e-10)  # R = I


@pytest.mark.parametrize("scale", [1e-200, 1e200, 1e300])
def test_dlqr_is_scale_invariant_in_the_cost(scale: float) -> None:
    Ad, Bd = np.eye(2) + 0.1 * A, 0.1 * B
    ref = sla.solve_discrete_are(Ad, Bd, Q, R)
    res = dlqr(Ad, Bd, scale * Q, scale * R)
    assert res.success
    np.testing.assert_allclose(res.P / scale, ref, rtol=1e-9)
    ric = solve_discrete_riccati(Ad, Bd, scale * Q, scale * R)
    np.testing.assert_allclose(ric.P / scale, ref, rtol=1e-9)


def test_newton_kleinman_overflow_is_not_reported_solved() -> None:
    # Q ~ 1e300, R = 1: |P_1 - P_0|_F overflowed to inf and inf <= 1e-13 * inf stopped at
    # iteration 1 as SOLVED (P = the first Lyapunov iterate). The Hamiltonian spans 600 orders
    # of magnitude (scipy's solve_continuous_are returns P = 0 here); an error is the answer.
    Q_huge = np.array([[2e300, 1e300], [1e300, 2e300]])
    with pytest.raises(TaskspaceError):
        lqr(A, B, Q_huge, 1.0, NK, initial_gain=[[1.0, 1.0]])
    with pytest.raises(SolverError):
        lqr(A, B, Q_huge, 1.0)


@pytest.mark.parametrize("tolerance", [np.nan, -1.0, "x"])
def test_newton_kleinman_tolerance_is_checked(tolerance: object) -> None:
    # NaN ran every iteration and returned NOT_CONVERGED
    options = LQROptions(riccati=RiccatiOptions(method="newton_kleinman", tolerance=tolerance))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="tolerance"):
        lqr(A, B, Q, R, options, initial_gain=[[1.0, 1.0]])


def test_riccati_overflow_inside_lapack_is_a_taskspace_error() -> None:
    # a bare ValueError "array must not contain infs or NaNs" (B R^-1 B^T overflowed)
    B_huge = np.array([[1e300], [2e300]])
    with pytest.raises(InvalidInputError, match="overflows"):
        solve_continuous_riccati(A, B_huge, Q, R)
    with pytest.raises(InvalidInputError, match="overflows"):
        solve_discrete_riccati(A, B_huge, Q, R)
    with pytest.raises(TaskspaceError):  # ordqz "reordering failed" was a bare ValueError
        solve_discrete_riccati(np.array([[1e300, 2e300], [1e300, 1e300]]), B, Q, R)
    with pytest.raises(SolverError):
        solve_discrete_lyapunov(np.array([[1e300, 2e300], [1e300, 1e300]]), Q)


@pytest.mark.parametrize("count", [np.nan, np.inf, 2.5, "10", True, 0, -3])
def test_finite_horizon_counts_are_integers(count: object) -> None:
    # NaN/inf gave bare ValueError/OverflowError, 2.5 ran 2 steps, "10" was parsed
    with pytest.raises(InvalidInputError):
        solve_riccati_recursion(A, B, Q, R, Q, count)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError):
        solve_riccati_differential(A, B, Q, R, Q, 1.0, count)  # type: ignore[arg-type]


def test_finite_horizon_table_larger_than_memory_is_refused_before_allocating() -> None:
    # a bare MemoryError (29 TiB) before
    with pytest.raises(InvalidInputError, match="GB"):
        solve_riccati_recursion(A, B, Q, R, Q, 10**12)
    with pytest.raises(InvalidInputError, match="GB"):
        solve_riccati_differential(A, B, Q, R, Q, 1.0, 10**12)


def test_finite_horizon_overflow_raises_instead_of_nan_gains() -> None:
    # RK4 with h = 10 s on a problem with R = 1e-12 diverges: every P and K was NaN
    with pytest.raises(SolverError, match="overflowed"):
        solve_riccati_differential(A, B, Q, 1e-12, 1e12 * np.eye(2), 100.0, 10)
    with pytest.raises(SolverError, match="overflowed"):
        solve_riccati_differential(A, B, Q, R, Q, 1e300, 10)
    with pytest.raises(SolverError, match="stage"):
        solve_riccati_recursion(1e10 * np.eye(2), [[0.0], [1e-300]], Q, R, Q, 100)
    # the recursion itself still matches the DARE when it converges (independent reference)
    Ad, Bd = np.eye(2) + 0.1 * A, 0.1 * B
    fh = solve_riccati_recursion(Ad, Bd, Q, R, Q, 400)
    np.testing.assert_allclose(fh.P[0], sla.solve_discrete_are(Ad, Bd, Q, R), rtol=1e-9)


def test_cost_and_lyapunov_value_check_x() -> None:
    fh = solve_riccati_recursion(A, B, Q, R, Q, 5)
    assert fh.cost([1.0, 0.0]) == pytest.approx(fh.P[0, 0, 0])
    with pytest.raises(InvalidInputError):  # bare matmul ValueError
        fh.cost([1.0, 2.0, 3.0])
    with pytest.raises(InvalidInputError):  # returned NaN
        fh.cost([np.nan, 1.0])
    cert = lyapunov_check(-np.eye(2), np.eye(2))
    assert cert.value(np.eye(2), [3.0, 4.0]) == 25.0
    with pytest.raises(InvalidInputError):
        cert.value(np.eye(2), [1.0, 2.0, 3.0])


@pytest.mark.parametrize("q", [1e-6, 1.0, 1e6, 1e9, 1e12, 1e14])
def test_care_against_the_closed_form_with_unbalanced_weights(q: float) -> None:
    # double integrator, Q = q I, R = 1: p12 = sqrt(q), p22 = sqrt(q + 2 p12), p11 = p12 p22.
    # The Schur method alone was 5e-6 off at q = 1e12 (relative residual 6e-6, SUCCESS); its
    # solution is now refined by Newton-Kleinman steps while the backward error decreases.
    p12 = np.sqrt(q)
    p22 = np.sqrt(q + 2.0 * p12)
    exact = np.array([[p12 * p22, p12], [p12, p22]])
    res = lqr(A, B, q * np.eye(2), 1.0)
    assert res.success
    np.testing.assert_allclose(res.P, exact, rtol=1e-9)
