"""Riccati and Lyapunov failures on extreme scaling name their real cause.

Before (loose3's sweep): ``lqr`` on the double integrator with ``R = 1e-300`` or ``Q = 1e300 I``
said "no stabilizing solution (is (A, B) stabilizable and (A, Q) detectable?)" though the
solution exists (closed form below); ``dlqr(1e200, 1, 1, 1)`` asked for a rescaling of "A, B,
Q and R" where its solution ``p ~ 1e400`` is simply beyond float64; ``solve_lyapunov`` of
``diag(-1e20, -1)`` (or ``A`` near -1e300 with an eigenvalue -1) said "A has opposite or
imaginary-axis eigenvalues"; a 1e100-scaled ``dlqr`` raised numpy's bare ``LinAlgError``.
The genuinely unsolvable problems still say so, naming the mode.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.control.controllability import controllability, controllability_matrix
from taskspace.control.lqr import dlqr, lqr
from taskspace.control.lyapunov import solve_lyapunov
from taskspace.control.observability import observability, observability_matrix
from taskspace.errors import InvalidInputError, SolverError

A = np.array([[0.0, 1.0], [0.0, 0.0]])
B = np.array([[0.0], [1.0]])


def _double_integrator_care(q1: float, q2: float, r: float) -> np.ndarray:
    """Closed form of the CARE of x'' = u with Q = diag(q1, q2), R = r."""
    s = math.sqrt(q1 * r)
    p22 = math.sqrt(r) * math.sqrt(q2 + 2 * s)  # (r (q2 + 2 s) underflows at r = 1e-300)
    return np.array([[math.sqrt(q1) * math.sqrt(q2 + 2 * s), s], [s, p22]])


@pytest.mark.parametrize(("Q", "R"), [(np.eye(2), 1e-300), (1e300 * np.eye(2), 1.0)])
def test_lqr_ill_conditioned_is_not_called_unsolvable(Q: np.ndarray, R: float) -> None:
    # the stabilizing solution exists and is representable (closed form)
    P = _double_integrator_care(Q[0, 0], Q[1, 1], R)
    assert np.all(np.isfinite(P)) and np.all(np.isfinite(P[:, 1] / R))
    with pytest.raises(SolverError) as info:
        lqr(A, B, Q, R)
    msg = str(info.value)
    assert "ill-conditioned" in msg and "a stabilizing solution exists" in msg
    assert "1e+150" in msg  # the Hamiltonian's largest eigenvalue, +-sqrt(sqrt(Q/R))-ish
    assert "is (A, B) stabilizable" not in msg


def test_lqr_moderate_scaling_still_matches_the_closed_form() -> None:
    res = lqr(A, B, 1e20 * np.eye(2), 1.0)
    np.testing.assert_allclose(res.P, _double_integrator_care(1e20, 1e20, 1.0), rtol=1e-9)


def test_unsolvable_riccati_names_the_mode() -> None:
    # an undamped oscillator with Q = 0: its modes +-i are unobservable through Q, the
    # Hamiltonian has them on the imaginary axis: no stabilizing solution (scipy returns a P
    # whose closed loop keeps them there)
    osc = np.array([[0.0, 1.0], [-1.0, 0.0]])
    P = sla.solve_continuous_are(osc, B, np.zeros((2, 2)), np.eye(1))
    assert np.max(np.linalg.eigvals(osc - B @ B.T @ P).real) > -1e-8
    with pytest.raises(SolverError, match=r"imaginary axis are not weighed by Q.*1j"):
        lqr(osc, B, 0.0, 1.0)
    with pytest.raises(SolverError, match=r"unit circle are not weighed by Q.*1j"):
        dlqr(osc, B, 0.0, 1.0)
    # an unstable mode unobservable through Q is no obstacle: p = 2 for x' = x + u, Q = 0
    res = lqr([[1.0]], [[1.0]], 0.0, 1.0)
    assert res.success and res.P[0, 0] == pytest.approx(2.0, rel=1e-12)


@pytest.mark.parametrize("a", [1e200, -1e200])
def test_dlqr_solution_beyond_float64_says_so(a: float) -> None:
    # p solves p^2 + p (r - q - a^2 r) - q r = 0 (b = 1): p = a^2 + O(1) = 1e400
    with pytest.raises(SolverError, match=r"beyond float64.*1e400"):
        dlqr([[a]], [[1.0]], 1.0, 1.0)
    # a representable one is solved: a = 1e100, p = a^2 + q - r + O(a^-2) = 1e200
    res = dlqr([[1e100]], [[1.0]], 1.0, 1.0)
    assert res.P[0, 0] == pytest.approx(1e200, rel=1e-12)


def test_dlqr_singular_gain_matrix_is_a_solver_error() -> None:
    # numpy's bare LinAlgError "Singular matrix" before (R + B^T P B with P ~ 1e200)
    rng = np.random.default_rng(0)
    raised = 0
    for _ in range(20):
        Ad, Bd = 1e100 * rng.standard_normal((1, 1)), rng.standard_normal((1, 2))
        try:
            dlqr(Ad, Bd, np.eye(1), 1.0)
        except SolverError:
            raised += 1
    assert raised > 0


@pytest.mark.parametrize(
    "A_lyap",
    [np.diag([-1e20, -1.0]), np.array([[-1e300, 1.0], [0.0, -1.0]]), np.diag([-1e300, -1.0])],
)
def test_lyapunov_wide_spectrum_is_not_called_opposite(A_lyap: np.ndarray) -> None:
    with pytest.raises(SolverError) as info:
        solve_lyapunov(A_lyap, np.eye(2))
    msg = str(info.value)
    assert "ill-conditioned" in msg and "not opposite" in msg
    assert "opposite or imaginary-axis eigenvalues" not in msg


def test_lyapunov_opposite_eigenvalues_still_named() -> None:
    with pytest.raises(SolverError, match="opposite or imaginary-axis eigenvalues"):
        solve_lyapunov([[0.0, 1.0], [-1.0, 0.0]], np.eye(2))
    with pytest.raises(SolverError, match="opposite or imaginary-axis eigenvalues"):
        solve_lyapunov(np.diag([2.0, -2.0]), np.eye(2))
    # and a spread within float64's reach is solved (diagonal: P = diag(1 / (2 |lambda|)))
    P = solve_lyapunov(np.diag([-1e11, -1.0]), np.eye(2))
    np.testing.assert_allclose(P, np.diag([5e-12, 0.5]), rtol=1e-14)


@pytest.mark.parametrize(("q1", "r"), [(1e300, 1.0), (1.0, 1e-300), (1e200, 1e-100)])
def test_lqr_wide_but_well_posed_weights_are_solved(q1: float, r: float) -> None:
    # Q = diag(q1, 0): the closed-loop poles are sqrt(2)/2 (q1/r)^(1/4) (-1 +- i), one
    # magnitude, but P spans 150 orders (1.4e225, 1e150, 1.4e75 for q1 = 1e300, r = 1): the
    # symplectic balancing needs scales beyond 2^256, where it stopped (then "no stabilizing
    # solution")
    res = lqr(A, B, np.diag([q1, 0.0]), r)
    assert res.success
    np.testing.assert_allclose(res.P, _double_integrator_care(q1, 0.0, r), rtol=1e-12)
    K = np.array([[math.sqrt(q1 / r), math.sqrt(2.0) * (q1 / r) ** 0.25]])
    np.testing.assert_allclose(res.K, K, rtol=1e-12)


def test_lqr_controllability_check_does_not_overflow() -> None:
    # A near 1e200 with 3 states: [B, AB, A^2 B] overflows (A^2 B ~ 1e400) and lqr refused the
    # (controllable) pair, "the controllability matrix overflows". The check runs on A / 2^e.
    # Reference: A is stable and P ~ 1e-200, so the quadratic term P B R^-1 B^T P (~1e-400)
    # is far below rounding and P is the Lyapunov solution 1e-200 P1, A1^T P1 + P1 A1 + Q = 0
    # (scipy, on the moderate A1)
    A1 = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.0, 0.0, -3.0]])
    B3 = np.array([[0.0], [0.0], [1.0]])
    res = lqr(1e200 * A1, B3, np.eye(3), 1.0)
    assert res.success and res.stable
    P1 = sla.solve_continuous_lyapunov(A1.T, -np.eye(3))
    np.testing.assert_allclose(res.P, 1e-200 * P1, rtol=1e-12)
    # an uncontrollable pair at that scale is still refused, its mode named at its scale
    with pytest.raises(InvalidInputError, match=r"not controllable.*-3e\+200"):
        lqr(1e200 * np.diag([-1.0, -2.0, -3.0]), [[1.0], [1.0], [0.0]], np.eye(3), 1.0)


_A1 = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.0, 0.0, -3.0]])


@pytest.mark.parametrize("c", [1e120, 1e200, -1e250, 2.0**900])
@pytest.mark.parametrize(
    ("A1", "B1", "modes"),
    [
        (_A1, [[0.0], [0.0], [1.0]], []),  # controllable from the last state
        (np.diag([-1.0, -2.0, -3.0]), [[1.0], [1.0], [0.0]], [-3.0]),  # x3 unreachable
        # a repeated mode (listed once per eigenvalue)
        (np.diag([-1.0, -1.0, -2.0]), [[1.0], [1.0], [1.0]], [-1.0, -1.0]),
    ],
)
def test_controllability_of_a_huge_A_is_that_of_the_moderate_A(c, A1, B1, modes) -> None:  # type: ignore[no-untyped-def]
    # The rank of [B, cAB, c^2 A^2 B] is that of [B, AB, A^2 B] (c != 0) and the modes scale
    # by c. [B, AB, A^2 B] overflowed (A^2 B ~ 1e400) and controllability refused the pair
    # ("overflows"). Reference: numpy's matrix_rank of the moderate controllability matrix,
    # the analytic modes.
    B1 = np.asarray(B1)
    K = np.hstack([B1, A1 @ B1, A1 @ A1 @ B1])
    rep = controllability(c * A1, B1)
    assert rep.rank == np.linalg.matrix_rank(K)
    assert rep.controllable == (not modes)
    got = np.sort_complex(rep.uncontrollable_modes)
    np.testing.assert_allclose(got, np.sort(c * np.array(modes, dtype=float)), rtol=1e-12)
    obs = observability((c * A1).T, B1.T)
    assert obs.rank == rep.rank


def test_controllability_overflow_names_the_matrix_its_norm_and_the_scaling() -> None:
    # The message said only "the controllability matrix ... overflows float64 (entries beyond
    # 1.8e308): rescale the state or the time unit".
    with pytest.raises(
        InvalidInputError,
        match=r"at A\^2 B: \|A\|_2 = 1e\+200, \|B\|_2 = 1\.73.*A / 2\^e.*exact",
    ):
        controllability_matrix(1e200 * np.eye(3), np.ones((3, 1)))
    # A whose entries span more than the floats: 2^-e A would lose the small ones
    A_wide = np.array([[1e200, 1e-200, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    with pytest.raises(InvalidInputError, match=r"A / 2\^665 would lose its smallest entries"):
        controllability(A_wide, np.ones((3, 1)))
    # B too large even for 2^-e A: the norms tell which
    with pytest.raises(
        InvalidInputError,
        match=r"at A B: \|A\|_2 = 1\.83 \(after A / 2\^499\), \|B\|_2 = 1\.73e\+308",
    ):
        controllability(1e150 * np.ones((3, 3)), 1e308 * np.ones((3, 1)))


def test_observability_overflow_names_its_own_matrix_norms_and_scaling() -> None:
    # observability_matrix said only "overflows float64 (entries beyond 1.8e308): rescale ...";
    # observability's refusals named "the controllability matrix [B, AB, ...]" and |B|.
    with pytest.raises(
        InvalidInputError,
        match=r"observability matrix \[C; CA; \.\.\.; CA\^\(n-1\)\] overflows float64 .* at "
        r"C A\^2: \|A\|_2 = 1e\+200, \|C\|_2 = 1\.73.*A / 2\^e.*exact",
    ):
        observability_matrix(1e200 * np.eye(3), np.ones((1, 3)))
    A_wide = np.array([[1e200, 1e-200, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    with pytest.raises(
        InvalidInputError, match=r"observability matrix .*A / 2\^665 would lose its smallest"
    ):
        observability(A_wide, np.ones((1, 3)))
    with pytest.raises(
        InvalidInputError,
        match=r"observability matrix .* at C A: \|A\|_2 = 1\.83 \(after A / 2\^499\), "
        r"\|C\|_2 = 1\.73e\+308",
    ):
        observability(1e150 * np.ones((3, 3)), 1e308 * np.ones((1, 3)))


def test_observability_matrix_is_the_stack_of_the_powers() -> None:
    # reference: C A^k by numpy's matrix_power, stacked
    A = np.array([[0.5, 1.0, 0.0], [0.0, -2.0, 1.0], [3.0, 0.0, 1.5]])
    C = np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 0.0]])
    ref = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(3)])
    np.testing.assert_array_equal(observability_matrix(A, C), ref)
    np.testing.assert_array_equal(observability_matrix(A, [1.0, 0.0, 2.0]), ref[::2])
