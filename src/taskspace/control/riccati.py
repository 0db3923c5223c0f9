"""Algebraic Riccati equations of infinite-horizon linear-quadratic control.

Continuous (CARE): ``A^T P + P A - P B R^-1 B^T P + Q = 0``; discrete (DARE):
``P = Q + A^T P A - A^T P B (R + B^T P B)^-1 B^T P A``. The stabilizing solution is wanted.

Methods:
* Hamiltonian Schur (Laub): the stable invariant subspace ``[U11; U21]`` of
  ``H = [[A, -B R^-1 B^T], [-Q, -A^T]]`` (ordered real Schur form) gives ``P = U21 U11^-1``.
* Newton-Kleinman: from a stabilizing gain ``K_0``, solve the Lyapunov equation
  ``(A - B K_k)^T P_k + P_k (A - B K_k) + Q + K_k^T R K_k = 0`` and set
  ``K_{k+1} = R^-1 B^T P_k``; converges quadratically.
* DARE: the stable deflating subspace of the symplectic pencil
  ``[[A, 0], [-Q, I]] - z [[I, B R^-1 B^T], [0, A^T]]`` (ordered QZ), ``P = Z21 Z11^-1``
  (works for singular ``A``).

Thread safety: the functions keep their state local to the call; :class:`RiccatiMethod`,
:class:`RiccatiOptions` and :class:`RiccatiStatus` are immutable; a :class:`RiccatiResult` is plain
result data (arrays), not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from taskspace._validation import FloatArray, as_matrix, check_count, check_positive
from taskspace.control._linear import (
    check_overflow,
    check_solution,
    safe_norm,
    symmetric_psd,
    system,
)
from taskspace.control.lyapunov import solve_discrete_lyapunov, solve_lyapunov
from taskspace.errors import InvalidInputError, SolverError


class RiccatiMethod(enum.Enum):
    """Algorithm of :func:`solve_continuous_riccati`."""

    SCHUR = "schur"
    NEWTON_KLEINMAN = "newton_kleinman"


class RiccatiStatus(enum.Enum):
    """Outcome of a Riccati solve."""

    SOLVED = "solved"
    MAX_ITERATIONS = "max_iterations"
    """Newton-Kleinman stopped at its iteration limit; ``P`` is its last iterate."""


@dataclass(frozen=True, kw_only=True)
class RiccatiOptions:
    """Settings of the Riccati solvers.

    Attributes:
        method: ``"schur"`` (default) or ``"newton_kleinman"`` (continuous only).
        max_iterations: Newton-Kleinman iteration limit.
        tolerance: Newton-Kleinman stops when ``|P_k - P_{k-1}|_F <= tolerance |P_k|_F``.
    """

    method: RiccatiMethod | str = RiccatiMethod.SCHUR
    max_iterations: int = 100
    tolerance: float = 1e-13


@dataclass
class RiccatiResult:
    """Solution of an algebraic Riccati equation.

    Attributes:
        success: ``P`` is the stabilizing solution within tolerance.
        status: see :class:`RiccatiStatus`.
        P: the solution (n x n), symmetric positive semidefinite.
        residual: relative residual ``|Ric(P)|_F / max(1, |P|_F)`` of the problem with ``Q``
            and ``R`` divided by the power of two nearest their largest entry (``P`` scales
            with them; the gain does not).
        iterations: Newton iterations (0 for the Schur methods).
        solve_time: wall time [s].
        method: the method used.
    """

    success: bool
    status: RiccatiStatus
    P: FloatArray
    residual: float
    iterations: int
    solve_time: float
    method: str


def _problem(
    A: Any, B: Any, Q: Any, R: Any
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    A, B = system(A, B)
    n, m = B.shape
    Q = symmetric_psd(Q, "Q", n, definite=False)
    R = symmetric_psd(R, "R", m, definite=True)
    return A, B, Q, R


def care_residual(A: Any, B: Any, Q: Any, R: Any, P: Any) -> float:
    """``|A^T P + P A - P B R^-1 B^T P + Q|_F / max(1, |P|_F)``."""
    A, B, Q, R = _problem(A, B, Q, R)
    return _care_residual(A, B, Q, R, as_matrix(P, A.shape, "P"))


def _care_residual(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray
) -> float:
    with np.errstate(over="ignore", invalid="ignore"):
        res = A.T @ P + P @ A - P @ B @ np.linalg.solve(R, B.T @ P) + Q
        return float(safe_norm(res) / max(1.0, safe_norm(P)))


def dare_residual(A: Any, B: Any, Q: Any, R: Any, P: Any) -> float:
    """``|Q + A^T P A - A^T P B (R + B^T P B)^-1 B^T P A - P|_F / max(1, |P|_F)``."""
    A, B, Q, R = _problem(A, B, Q, R)
    return _dare_residual(A, B, Q, R, as_matrix(P, A.shape, "P"))


def _dare_residual(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray
) -> float:
    with np.errstate(over="ignore", invalid="ignore"):
        BtPA = B.T @ P @ A
        res = Q + A.T @ P @ A - BtPA.T @ np.linalg.solve(R + B.T @ P @ B, BtPA) - P
        return float(safe_norm(res) / max(1.0, safe_norm(P)))


_RESCALE = "rescale the problem (state and input units) so that A, B, Q and R have moderate entries"


def _cost_exponent(Q: FloatArray, R: FloatArray) -> int:
    """Exponent ``e`` of the power of two nearest ``max(|Q|, |R|)``.

    ``P(2^-e Q, 2^-e R) = 2^-e P(Q, R)`` exactly (powers of two scale without rounding) and
    ``K`` is unchanged; solving the scaled problem keeps the Hamiltonian balanced: Q, R near
    1e-200 or 1e200 made the Schur method report "no stabilizing solution" and Newton-Kleinman
    stop at its second iterate (P off by 27 %). Even moderate
    scales matter: Q = R = 1e9 I gave P 49 % off with SUCCESS on the double integrator.
    """
    top = max(float(np.abs(Q).max()), float(np.abs(R).max()))
    return math.frexp(top)[1] if top > 0 else 0


def _gain_matrix(B: FloatArray, R: FloatArray) -> FloatArray:
    """``B R^-1 B^T``, refusing an overflow (huge ``B`` or tiny ``R``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        G = B @ np.linalg.solve(R, B.T)
    return check_overflow(G, "B R^-1 B^T", _RESCALE)


def _method(value: RiccatiMethod | str) -> RiccatiMethod:
    if isinstance(value, RiccatiMethod):
        return value
    try:
        return RiccatiMethod(value)
    except ValueError:
        valid = ", ".join(m.value for m in RiccatiMethod)
        raise InvalidInputError(
            f"unknown Riccati method {value!r}; valid methods are: {valid}"
        ) from None


_gebal = sla.lapack.dgebal

_MAX_BALANCE_EXPONENT = 500
"""Largest ``|log2 d_i|`` of the symplectic balancing: ``d_i d_j`` stays a normal float64
(``2^+-1000``), so ``P = D P' D`` loses no digits (overflow shows as a non-finite ``P``).
Was 256: the double integrator with ``Q = diag(1e300, 0), R = 1`` (``P`` from 1e-225 to
1e-75 after the cost scaling) needed 2^372 and was reported unsolvable."""


def _symplectic_scaling(M: FloatArray) -> FloatArray | None:
    """Powers of two ``d`` (n): ``S = diag(d, 1/d)`` balances the 2n x 2n ``M`` (or None).

    As scipy's ``solve_continuous_are(balanced=True)`` (Benner's symplectic balancing):
    LAPACK's ``gebal`` scaling of ``|M|`` without its diagonal, made symplectic by taking
    the geometric mean of the two halves. ``S M S^-1`` keeps the Hamiltonian (symplectic)
    structure, so its stable subspace gives ``P' = D^-1 P D^-1`` (``D = diag(d)``), exactly:
    ``P = D P' D``. Without it the double integrator with ``Q = 1e-15 I, R = 1`` gave P 14 %
    off (1e-12 I: 2e-4) with a backward error at rounding level.
    """
    n = M.shape[0] // 2
    W = np.abs(M)
    np.fill_diagonal(W, 0.0)
    # LAPACK dgebal directly (scaling only): scipy.linalg.matrix_balance costs 25 us more.
    _, _, _, scale, info = _gebal(W, scale=1, permute=0, overwrite_a=1)
    values = scale.tolist()  # Python scalars: NumPy calls on 2n entries cost ~40 us more
    if info != 0 or not all(math.isfinite(v) and v > 0 for v in values):
        return None  # no scaling rather than a failure
    # gebal's scales are powers of two; round() is half-to-even as scipy's np.round
    e = [math.frexp(v)[1] for v in values]
    exponent = [round(0.5 * (e[n + i] - e[i])) for i in range(n)]
    if not any(exponent) or max(map(abs, exponent)) > _MAX_BALANCE_EXPONENT:
        return None  # balanced already, or beyond _MAX_BALANCE_EXPONENT
    return np.exp2(np.array(exponent, dtype=float))


def _pbh_failures(A: FloatArray, M: FloatArray, modes: np.ndarray, *, rows: bool) -> list[complex]:
    """The ``modes`` uncontrollable (``rows``: unobservable) through ``M`` (PBH test).

    Eigenvalues at which ``[A - lambda I, M]`` (``rows``: ``[A - lambda I; M]``) loses rank.

    The PBH test with the two blocks scaled separately by their largest entry (the rank is
    unchanged), so that a ``G = B R^-1 B^T`` near 1e300 does not hide ``A``; relative rank
    threshold ``1e3 n eps``.
    """
    n = A.shape[0]
    eye = np.eye(n)
    out = []
    with np.errstate(over="ignore", invalid="ignore"):
        sm = float(np.max(np.abs(M))) if M.size else 0.0
        if sm == 0.0 or not math.isfinite(sm):
            return [complex(lam) for lam in modes] if sm == 0.0 else []
        for lam in modes:
            D = A - lam * eye
            sd = float(np.max(np.abs(D)))
            D = D / sd if sd > 0 else D
            block = np.vstack([D, M / sm]) if rows else np.hstack([D, M / sm])
            if not np.all(np.isfinite(block)):
                continue
            sv = np.linalg.svd(block, compute_uv=False)
            if sv.size < n or sv[n - 1] <= 1e3 * n * np.finfo(float).eps * sv[0]:
                out.append(complex(lam))
    return out


def _no_solution_cause(
    A: FloatArray,
    G: FloatArray,
    Q: FloatArray,
    eigs: np.ndarray,
    what: str,
    discrete: bool,
    subspace_cond: float | None = None,
) -> str:
    """Why the stable subspace was not found (the tail of the error message).

    The mode that makes the problem unsolvable, or else the numerical cause. ``(A, B)``
    stabilizable (``G = B R^-1 B^T`` has the range of ``B``) and no mode of ``A`` on the
    stability boundary (imaginary axis, unit circle) unobservable through ``Q`` guarantee a
    stabilizing solution: when the PBH tests say both hold, the failure is numerical.
    Before, the double integrator with ``R = 1e-300`` (or ``Q = 1e300 I``) was reported
    "no stabilizing solution (is (A, B) stabilizable and (A, Q) detectable?)" though both
    hold: its Hamiltonian has eigenvalues +-1e150 and +-1, the latter below the rounding of
    ``|H|`` (computed as 0).
    """
    try:
        lam = np.linalg.eigvals(A)
    except np.linalg.LinAlgError:
        lam = np.zeros(0, dtype=complex)
    unstable = lam[np.abs(lam) >= 1.0] if discrete else lam[lam.real >= 0.0]
    with np.errstate(over="ignore", invalid="ignore"):
        if discrete:
            boundary = lam[np.abs(np.abs(lam) - 1.0) <= 1e-9 * np.maximum(1.0, np.abs(lam))]
        else:
            size = float(np.max(np.abs(A))) if A.size else 0.0
            boundary = lam[np.abs(lam.real) <= 1e-9 * max(size, 1e-300)]
    bad_b = _pbh_failures(A, G, unstable, rows=False)
    bad_q = _pbh_failures(A, Q, boundary, rows=True)
    fmt = lambda modes: ", ".join(f"{complex(m):.4g}" for m in modes)  # noqa: E731
    if bad_b:
        return (
            f"no stabilizing solution: (A, B) is not stabilizable (unstable modes of A that B "
            f"does not reach: [{fmt(bad_b)}])"
        )
    if bad_q:
        where = "on the unit circle" if discrete else "on the imaginary axis"
        return (
            f"no stabilizing solution: modes of A {where} are not weighed by Q (unobservable "
            f"through Q: [{fmt(bad_q)}]; add a weight on them to Q)"
        )
    mags = np.abs(eigs[np.isfinite(eigs)]) if eigs.size else np.zeros(0)
    top = float(mags.max()) if mags.size else float("nan")
    low = float(mags.min()) if mags.size else float("nan")
    eps = float(np.finfo(float).eps)
    head = (
        "the problem is too ill-conditioned for float64: (A, B) is stabilizable and Q weighs "
        "every mode of A on the stability boundary, so a stabilizing solution exists, but"
    )
    tail = (
        "Bring the weights Q and R closer (their ratio sets the fastest poles) or the state's "
        "scales (the entries of A, B) closer together"
    )
    side = "inside the unit circle" if discrete else "in the left half-plane"
    if mags.size and low <= 1e3 * eps * top:
        return (
            f"{head} the {what}'s eigenvalues span more orders of magnitude than float64 "
            f"resolves (|lambda| from {low:.3g} to {top:.3g}; below about {1e3 * eps * top:.3g} "
            f"= 1e3 eps |lambda|max they are rounding noise, and so is whether they lie {side}): "
            f"the closed-loop poles would span as much. {tail}"
        )
    if subspace_cond is not None:
        return (
            f"{head} P = X21 X11^-1 from the stable subspace is not determined in float64: X11 "
            f"has condition number {subspace_cond:.3g} (P's own scales span about "
            f"{math.log10(max(subspace_cond, 1.0)):.0f} orders of magnitude or more; the "
            f"{what}'s eigenvalues have |lambda| from {low:.3g} to {top:.3g}). {tail}"
        )
    return (
        f"{head} the {what}'s eigenvalues (|lambda| from {low:.3g} to {top:.3g}) are not "
        f"separated {side} to float64 precision. {tail}"
    )


def _care_schur(A: FloatArray, G: FloatArray, Q: FloatArray) -> FloatArray:
    n = A.shape[0]
    H = np.block([[A, -G], [-Q, -A.T]])
    d = _symplectic_scaling(H)
    if d is not None:
        S = np.concatenate([d, 1.0 / d])
        H = H * (S[:, None] / S[None, :])  # exact: powers of two
    try:
        T, U, sdim = sla.schur(H, output="real", sort="lhp")
    except (ValueError, np.linalg.LinAlgError) as exc:  # overflow inside LAPACK
        raise SolverError(
            f"the ordered Schur form of the Hamiltonian failed ({exc}): rescale the problem "
            "(state and input units) so that A, B, Q and R have moderate entries"
        ) from exc
    if sdim != n:
        cause = _no_solution_cause(A, G, Q, np.linalg.eigvals(T), "Hamiltonian", False)
        raise SolverError(
            f"the Hamiltonian matrix has {2 * n - sdim} eigenvalues with Re >= 0 instead of {n}: "
            f"{cause}"
        )
    U11, U21 = U[:n, :n], U[n:, :n]
    cond = float(np.linalg.cond(U11))
    if not cond <= 1e12:
        cause = _no_solution_cause(A, G, Q, np.linalg.eigvals(T), "Hamiltonian", False, cond)
        raise SolverError(
            f"U11 of the stable invariant subspace is singular (condition number {cond:.3g}): "
            f"{cause}"
        )
    P = np.linalg.solve(U11.T, U21.T).T
    if d is not None:
        with np.errstate(over="ignore", invalid="ignore"):
            P = P * d[:, None] * d[None, :]
    return check_solution(0.5 * (P + P.T), "the CARE solution P")


REFINE_RESIDUAL = 1e-13
"""Backward error of the CARE (see :func:`_care_errors`) above which the Schur
solution is refined by Newton-Kleinman steps."""


def _care_errors(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray
) -> tuple[float, float]:
    """The reported residual ``|Ric(P)|_F / max(1, |P|_F)`` and the backward error.

    The backward error ``|Ric(P)|_F / (|A^T P + P A|_F + |P G P|_F + |Q|_F)`` is scale-free,
    unlike the reported residual (a tiny P looked exact with 2e-4 relative error).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        lin = A.T @ P + P @ A
        quad = P @ B @ np.linalg.solve(R, B.T @ P)
        r = safe_norm(lin - quad + Q)
        den = safe_norm(lin) + safe_norm(quad) + safe_norm(Q)
        return float(r / max(1.0, safe_norm(P))), (float(r / den) if den > 0 else 0.0)


ACCEPT_BACKWARD_ERROR = 1e-8
"""Backward error above which a Riccati solution is refused (:class:`SolverError`) rather
than returned: on the double integrator with Q ~ 2e300 (R = 1, the Hamiltonian spans 600
decades) the Schur solution was P 1e44 times off."""


def _check_accuracy(backward: float, equation: str) -> None:
    if not backward <= ACCEPT_BACKWARD_ERROR:
        raise SolverError(
            f"the {equation} solution is inaccurate (scale-free backward error {backward:.1e} > "
            f"{ACCEPT_BACKWARD_ERROR:g}): {_RESCALE}"
        )


def _refine(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray
) -> tuple[FloatArray, int]:
    """Newton-Kleinman steps from the Schur solution while its backward error decreases.

    The ordered Schur method alone left backward errors of 1e-6 (Q = 1e12 I, R = 1 on the
    double integrator: relative residual 6e-6) and P entries 2e-4 off (Q = 1e-12 I) against
    the closed form; Newton's method from its stabilizing gain converges quadratically. At
    most 8 steps, only when the backward error exceeds :data:`REFINE_RESIDUAL`.
    """
    _, err = _care_errors(A, B, Q, R, P)
    steps = 0
    for k in range(1, 9):
        if not err > REFINE_RESIDUAL:
            break
        with np.errstate(over="ignore", invalid="ignore"):
            K = np.linalg.solve(R, B.T @ P)
            try:
                P_new = solve_lyapunov(A - B @ K, Q + K.T @ R @ K)
            except (SolverError, InvalidInputError):
                break
        if not np.all(np.isfinite(P_new)):
            break
        _, err_new = _care_errors(A, B, Q, R, P_new)
        if not err_new < err:
            break
        P, err, steps = P_new, err_new, k
    return P, steps


def _dare_errors(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray
) -> tuple[float, float]:
    """The reported residual ``|Ric_d(P)|_F / max(1, |P|_F)`` and the backward error.

    The backward error ``|Ric_d(P)|_F / (|Q|_F + |A^T P A|_F + |A^T P B (R + B^T P B)^-1
    B^T P A|_F + |P|_F)`` is scale-free.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        BtPA = B.T @ P @ A
        AtPA = A.T @ P @ A
        S = R + B.T @ P @ B
        try:
            quad = BtPA.T @ np.linalg.solve(S, BtPA)
        except np.linalg.LinAlgError:  # a bare "Singular matrix" before (A ~ 1e100)
            raise SolverError(
                f"R + B^T P B is singular in float64 (|B^T P B| = {safe_norm(S - R):.3g} "
                f"swamps |R| = {safe_norm(R):.3g}, or P is wrong): the DARE solution cannot be "
                f"checked; {_RESCALE}"
            ) from None
        r = safe_norm(Q + AtPA - quad - P)
        size = safe_norm(P)
        den = safe_norm(Q) + safe_norm(AtPA) + safe_norm(quad) + size
        return float(r / max(1.0, size)), (float(r / den) if den > 0 else 0.0)


def _refine_discrete(
    A: FloatArray, B: FloatArray, Q: FloatArray, R: FloatArray, P: FloatArray, err: float
) -> tuple[FloatArray, int]:
    """Newton (Hewer) steps from the QZ solution while its backward error decreases.

    ``K = (R + B^T P B)^-1 B^T P A``, then ``P`` solves the Stein equation
    ``(A - B K)^T P (A - B K) - P + Q + K^T R K = 0``: quadratic convergence from a
    stabilizing gain, as :func:`_refine` for the CARE. At most 8 steps, only when the
    backward error exceeds :data:`REFINE_RESIDUAL`.
    """
    steps = 0
    for k in range(1, 9):
        if not err > REFINE_RESIDUAL:
            break
        with np.errstate(over="ignore", invalid="ignore"):
            K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
            try:
                P_new = solve_discrete_lyapunov(A - B @ K, Q + K.T @ R @ K)
            except (SolverError, InvalidInputError, np.linalg.LinAlgError):
                break
        if not np.all(np.isfinite(P_new)):
            break
        P_new = 0.5 * (P_new + P_new.T)
        _, err_new = _dare_errors(A, B, Q, R, P_new)
        if not err_new < err:
            break
        P, err, steps = P_new, err_new, k
    return P, steps


def _dare_cause(
    A: FloatArray,
    B: FloatArray,
    R: FloatArray,
    G: FloatArray,
    Q: FloatArray,
    L: FloatArray,
    N: FloatArray,
    subspace_cond: float | None = None,
) -> str:
    """:func:`_no_solution_cause` for the DARE, first the size of its solution.

    For an unstable ``A`` the solution grows like ``P ~ |A|^2 |R| / |B|^2`` (scalar:
    ``p = a^2 r / b^2 + O(1)``): beyond float64 when ``|A|`` nears 1e154 (``dlqr(1e200, 1, 1,
    1)`` has ``p = 1e400``; the QZ reordering failed and the message asked for a rescaling).
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        try:
            rho = float(np.max(np.abs(np.linalg.eigvals(A))))
            b = float(np.linalg.norm(B, 2))
            r = float(np.max(np.linalg.eigvalsh(R)))
        except np.linalg.LinAlgError:
            rho, b, r = float("nan"), float("nan"), float("nan")
        # in logarithms: the estimate itself overflows
        log_p = (
            2 * math.log10(rho) + math.log10(r) - 2 * math.log10(b)
            if (rho > 1.0 and b > 0 and r > 0 and math.isfinite(rho * 0 + b * 0 + r * 0))
            else -math.inf
        )
    if log_p > 308.0:
        return (
            f"the solution P is beyond float64: for the unstable A (spectral radius {rho:.3g}) "
            f"P grows like rho(A)^2 |R| / |B|^2 ~ 1e{log_p:.0f} (largest float64 1.8e308); "
            "rescale the state (smaller A entries: a shorter sampling time) or the weights"
        )
    try:
        eigs = sla.eigvals(L, N)
    except (ValueError, np.linalg.LinAlgError):
        eigs = np.zeros(0, dtype=complex)
    eigs = eigs[np.isfinite(eigs)]
    return _no_solution_cause(A, G, Q, eigs, "symplectic pencil", True, subspace_cond)


def solve_continuous_riccati(
    A: Any,
    B: Any,
    Q: Any,
    R: Any,
    options: RiccatiOptions | None = None,
    *,
    initial_gain: Any = None,
) -> RiccatiResult:
    """Stabilizing solution of ``A^T P + P A - P B R^-1 B^T P + Q = 0``.

    Args:
        A: (n x n); B: (n x m); Q: (n x n) symmetric >= 0; R: (m x m) symmetric > 0 (scalars
            are multiples of the identity).
        options: method and Newton-Kleinman settings.
        initial_gain: stabilizing ``K_0`` (m x n) for Newton-Kleinman; default 0 when ``A``
            is stable.

    Raises:
        InvalidInputError: bad shapes, non-symmetric/indefinite ``Q``/``R``; Newton-Kleinman
            without a stabilizing initial gain.
        SolverError: no stabilizing solution exists (Schur method).
    """
    options = options or RiccatiOptions()
    method = _method(options.method)
    A, B, Q_user, R_user = _problem(A, B, Q, R)
    n, m = B.shape
    t0 = time.perf_counter()
    e = _cost_exponent(Q_user, R_user)
    Q, R = (np.ldexp(Q_user, -e), np.ldexp(R_user, -e)) if e else (Q_user, R_user)
    G = _gain_matrix(B, R)
    iterations = 0
    status = RiccatiStatus.SOLVED
    if method is RiccatiMethod.SCHUR:
        P = _care_schur(A, G, Q)
    else:
        if initial_gain is None:
            if np.max(np.linalg.eigvals(A).real) >= 0:
                raise InvalidInputError(
                    "newton_kleinman needs a stabilizing initial gain K0 (A - B K0 stable) when "
                    "A is unstable: pass initial_gain=..., or use method='schur'"
                )
            K = np.zeros((m, n))
        else:
            K = as_matrix(initial_gain, (m, n), "initial_gain")
            if np.max(np.linalg.eigvals(A - B @ K).real) >= 0:
                raise InvalidInputError("initial_gain does not stabilize A - B K0")
        P = np.zeros((n, n))
        status = RiccatiStatus.MAX_ITERATIONS
        max_iterations = check_count(options.max_iterations, "max_iterations", minimum=1)
        tolerance = check_positive(options.tolerance, "RiccatiOptions.tolerance", strict=False)
        for iterations in range(1, max_iterations + 1):
            Ak = A - B @ K
            with np.errstate(over="ignore", invalid="ignore"):
                rhs = Q + K.T @ R @ K
            P_new = check_solution(
                solve_lyapunov(Ak, check_overflow(rhs, "Q + K^T R K", _RESCALE)),
                f"the Newton-Kleinman iterate P (iteration {iterations})",
            )
            with np.errstate(over="ignore", invalid="ignore"):
                K = np.linalg.solve(R, B.T @ P_new)
            check_overflow(K, "the Newton-Kleinman gain R^-1 B^T P", _RESCALE)
            with np.errstate(over="ignore", invalid="ignore"):
                change = safe_norm(P_new - P)  # np.linalg.norm was inf near 1e300, and
                size = safe_norm(P_new)  # inf <= tolerance * inf stopped at iteration 1
            P = P_new
            if change <= tolerance * size:  # relative (was absolute below |P| = 1)
                status = RiccatiStatus.SOLVED
                break
    residual, backward = _care_errors(A, B, Q, R, P)
    if method is RiccatiMethod.SCHUR and backward > REFINE_RESIDUAL:
        P, iterations = _refine(A, B, Q, R, P)
        residual, backward = _care_errors(A, B, Q, R, P)
    if status is RiccatiStatus.SOLVED:  # MAX_ITERATIONS already reports a failure
        _check_accuracy(backward, "CARE")
    P = check_solution(np.ldexp(P, e), "the CARE solution P") if e else P
    return RiccatiResult(
        success=status is RiccatiStatus.SOLVED,
        status=status,
        P=P,
        residual=residual,
        iterations=iterations,
        solve_time=time.perf_counter() - t0,
        method=method.value,
    )


def solve_discrete_riccati(
    A: Any, B: Any, Q: Any, R: Any, options: RiccatiOptions | None = None
) -> RiccatiResult:
    """Stabilizing solution of ``P = Q + A^T P A - A^T P B (R + B^T P B)^-1 B^T P A``.

    Ordered QZ on the symplectic pencil (see the module docstring).

    Args:
        A: (n x n); B: (n x m); Q: (n x n) symmetric >= 0; R: (m x m) symmetric > 0.
        options: unused except for validation (the method is always the Schur/QZ one).

    Raises:
        InvalidInputError: bad inputs, or ``method='newton_kleinman'`` (continuous only).
        SolverError: no stabilizing solution exists.
    """
    options = options or RiccatiOptions()
    if _method(options.method) is not RiccatiMethod.SCHUR:
        raise InvalidInputError("solve_discrete_riccati supports method='schur' only")
    A, B, Q_user, R_user = _problem(A, B, Q, R)
    n = A.shape[0]
    t0 = time.perf_counter()
    e = _cost_exponent(Q_user, R_user)
    Q, R = (np.ldexp(Q_user, -e), np.ldexp(R_user, -e)) if e else (Q_user, R_user)
    G = _gain_matrix(B, R)
    eye, zero = np.eye(n), np.zeros((n, n))
    L = np.block([[A, zero], [-Q, eye]])
    N = np.block([[eye, G], [zero, A.T]])
    d = _symplectic_scaling(np.abs(L) + np.abs(N))  # as scipy's solve_discrete_are
    if d is not None:
        S = np.concatenate([d, 1.0 / d])
        E = S[:, None] / S[None, :]  # exact: powers of two
        L, N = L * E, N * E
    try:
        _, _, alpha, beta, _, Z = sla.ordqz(L, N, sort="iuc", output="real")
    except (ValueError, np.linalg.LinAlgError) as exc:  # overflow or failed reordering
        raise SolverError(
            f"the ordered QZ decomposition of the symplectic pencil failed ({exc}): "
            f"{_dare_cause(A, B, R, G, Q, L, N)}"
        ) from exc
    stable = np.sum(np.abs(alpha) < np.abs(beta) * (1.0 - 1e-12))
    if stable != n:
        raise SolverError(
            f"the symplectic pencil has {stable} stable eigenvalues instead of {n}: "
            f"{_dare_cause(A, B, R, G, Q, L, N)}"
        )
    Z11, Z21 = Z[:n, :n], Z[n:, :n]
    cond = float(np.linalg.cond(Z11))
    if not cond <= 1e12:
        raise SolverError(
            f"Z11 of the stable deflating subspace is singular (condition number {cond:.3g}): "
            f"{_dare_cause(A, B, R, G, Q, L, N, cond)}"
        )
    P = np.linalg.solve(Z11.T, Z21.T).T
    if d is not None:
        with np.errstate(over="ignore", invalid="ignore"):
            P = P * d[:, None] * d[None, :]
    P = check_solution(0.5 * (P + P.T), "the DARE solution P")
    residual, backward = _dare_errors(A, B, Q, R, P)
    iterations = 0
    if backward > REFINE_RESIDUAL:
        P, iterations = _refine_discrete(A, B, Q, R, P, backward)
        residual, backward = _dare_errors(A, B, Q, R, P)
    _check_accuracy(backward, "DARE")
    P = check_solution(np.ldexp(P, e), "the DARE solution P") if e else P
    return RiccatiResult(
        success=True,
        status=RiccatiStatus.SOLVED,
        P=P,
        residual=residual,
        iterations=iterations,
        solve_time=time.perf_counter() - t0,
        method="schur",
    )
