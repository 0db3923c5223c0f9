"""Lyapunov equations and Lyapunov functions of linear systems.

Continuous time: ``A^T P + P A + Q = 0``; for ``Q > 0`` a solution ``P > 0`` exists iff ``A``
is stable, and ``V(x) = x^T P x`` is then a Lyapunov function: ``V > 0`` and
``V' = x^T (A^T P + P A) x = -x^T Q x < 0``. Discrete time: ``A^T P A - P + Q = 0`` with
``V(x+) - V(x) = -x^T Q x``.

Both equations are solved with the Bartels-Stewart method: complex Schur forms
``A^T = U R U^H`` and ``A = W S W^H`` turn the equation into a triangular one, solved column
by column with triangular solves (O(n^3)).

Thread safety: the functions keep their state local to the call; a :class:`LyapunovCertificate` is
plain result data, not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from taskspace._validation import FloatArray, as_vector
from taskspace.control._linear import check_solution, square
from taskspace.errors import InvalidInputError, SolverError

SINGULARITY_TOLERANCE = 1e-12
"""Relative size under which a diagonal pivot of the triangular equation counts as zero."""


def _schur_pair(A: FloatArray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    try:
        R, U = sla.schur(A.T, output="complex")
        S, W = sla.schur(A, output="complex")
    except (ValueError, np.linalg.LinAlgError) as exc:  # overflow inside LAPACK
        raise SolverError(f"the Schur form of A failed ({exc}): {_RESCALE}") from exc
    return R, U, S, W


_RESCALE = "rescale A and Q (state and time units) so that they have moderate entries"


def _solve_column(lhs: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore", invalid="ignore"):
        if not (np.all(np.isfinite(lhs)) and np.all(np.isfinite(rhs))):
            raise SolverError(f"the Lyapunov solve overflowed float64: {_RESCALE}")
        return np.asarray(sla.solve_triangular(lhs, rhs))


def _finish(X: np.ndarray, Q: FloatArray) -> FloatArray:
    """Real part of ``X``; symmetrized only when ``Q`` is symmetric (to rounding).

    A non-symmetric ``Q`` has a non-symmetric solution: symmetrizing it returned the solution
    for ``(Q + Q^T) / 2`` instead.
    """
    P = np.real(X)
    with np.errstate(over="ignore", invalid="ignore"):
        asymmetry = float(np.max(np.abs(Q - Q.T))) if Q.size else 0.0
        size = float(np.max(np.abs(Q))) if Q.size else 0.0
    if asymmetry <= 1e-12 * size:
        P = 0.5 * (P + P.T)
    return check_solution(P, "the Lyapunov solution P")


def _singular_continuous(lam_i: complex, lam_j: complex, pivot: float, scale: float) -> None:
    """Raise the :class:`SolverError` of a too small pivot, naming its cause.

    The pivot ``|lambda_i + lambda_j|`` is below ``SINGULARITY_TOLERANCE * max(1, |A|)``.
    Opposite or imaginary-axis eigenvalues when the pivot is small next to the eigenvalues
    themselves; otherwise the eigenvalues are fine but ``A`` spans too many orders of
    magnitude: both are far below ``|A|`` (``A = diag(-1e20, -1)``: ``-1 + -1 = -2`` is
    within the rounding of a Schur form of ``|A| = 1e20``), which was reported as "opposite
    or imaginary-axis eigenvalues" too.
    """
    size = max(abs(lam_i), abs(lam_j))
    pair = f"lambda_i = {lam_i:.4g}, lambda_j = {lam_j:.4g}"
    if pivot <= SINGULARITY_TOLERANCE * size:
        raise SolverError(
            "A^T P + P A + Q = 0 has no unique solution: A has eigenvalues with "
            f"lambda_i + lambda_j = 0 ({pair}; A must not have opposite or imaginary-axis "
            "eigenvalues)"
        )
    raise SolverError(
        "A^T P + P A + Q = 0 is too ill-conditioned for float64: A's eigenvalues span too many "
        f"orders of magnitude: |lambda_i + lambda_j| = {pivot:.3g} ({pair}) is below "
        f"{SINGULARITY_TOLERANCE:g} |A| = {SINGULARITY_TOLERANCE * scale:.3g} (|A| = "
        f"{scale:.3g}), within what the rounding of A's Schur form can move to zero (condition "
        f"number >= |A| / |lambda_i + lambda_j| = {scale / pivot:.3g}); the eigenvalues are not "
        "opposite. Separate the fast and slow modes (solve them apart) or rescale the state "
        "so that A's eigenvalues span fewer orders of magnitude"
    )


def solve_lyapunov(A: Any, Q: Any) -> FloatArray:
    """Solve ``A^T P + P A + Q = 0`` (Bartels-Stewart).

    Args:
        A: system matrix (n x n).
        Q: right-hand side (n x n), usually symmetric positive definite.

    Returns:
        ``P`` (n x n), symmetric when ``Q`` is.

    Raises:
        SolverError: ``A`` has eigenvalues with ``lambda_i + lambda_j = 0`` (no unique
            solution, e.g. a marginally stable or non-hyperbolic ``A``), or a sum
            ``|lambda_i + lambda_j|`` below ``SINGULARITY_TOLERANCE * |A|`` (eigenvalues
            spanning too many orders of magnitude: the message says which).
    """
    A = square(A, "A")
    n = A.shape[0]
    Q = square(Q, "Q", n)
    R, U, S, W = _schur_pair(A)
    with np.errstate(over="ignore", invalid="ignore"):
        F = U.conj().T @ (-Q) @ W
    Y = np.zeros((n, n), dtype=complex)
    scale = max(1.0, float(np.max(np.abs(A))) if A.size else 1.0)
    eye = np.eye(n)
    for k in range(n):
        lhs = R + S[k, k] * eye
        pivots = np.abs(np.diag(lhs))
        if pivots.size and np.min(pivots) <= SINGULARITY_TOLERANCE * scale:
            i = int(np.argmin(pivots))
            _singular_continuous(complex(R[i, i]), complex(S[k, k]), float(pivots[i]), scale)
        with np.errstate(over="ignore", invalid="ignore"):
            rhs = F[:, k] - Y[:, :k] @ S[:k, k]
        Y[:, k] = _solve_column(lhs, rhs)
    with np.errstate(over="ignore", invalid="ignore"):
        X = U @ Y @ W.conj().T
    return _finish(X, Q)


def solve_discrete_lyapunov(A: Any, Q: Any) -> FloatArray:
    """Solve ``A^T P A - P + Q = 0`` (Bartels-Stewart for the Stein equation).

    Raises:
        SolverError: ``A`` has eigenvalues with ``lambda_i lambda_j = 1`` (no unique solution).
    """
    A = square(A, "A")
    n = A.shape[0]
    Q = square(Q, "Q", n)
    R, U, S, W = _schur_pair(A)
    with np.errstate(over="ignore", invalid="ignore"):
        F = U.conj().T @ (-Q) @ W
    Y = np.zeros((n, n), dtype=complex)
    eye = np.eye(n)
    for k in range(n):
        with np.errstate(over="ignore", invalid="ignore"):
            lhs = S[k, k] * R - eye
        pivots = np.abs(np.diag(lhs))
        if pivots.size and np.min(pivots) <= SINGULARITY_TOLERANCE:
            raise SolverError(
                "A^T P A - P + Q = 0 has no unique solution: A has eigenvalues with "
                "lambda_i lambda_j = 1 (e.g. on the unit circle)"
            )
        with np.errstate(over="ignore", invalid="ignore"):
            rhs = F[:, k] - R @ (Y[:, :k] @ S[:k, k])
        Y[:, k] = _solve_column(lhs, rhs)
    with np.errstate(over="ignore", invalid="ignore"):
        X = U @ Y @ W.conj().T
    return _finish(X, Q)


@dataclass
class LyapunovCertificate:
    """Result of :func:`lyapunov_check` for ``V(x) = x^T P x``.

    Attributes:
        valid: ``P > 0`` and ``V`` strictly decreases along every trajectory.
        min_eigenvalue_P: smallest eigenvalue of ``P`` (> 0 required).
        max_eigenvalue_decrease: largest eigenvalue of ``A^T P + P A`` (continuous) or
            ``A^T P A - P`` (discrete) (< 0 required).
        discrete: discrete-time check.
    """

    valid: bool
    min_eigenvalue_P: float
    max_eigenvalue_decrease: float
    discrete: bool

    def value(self, P: Any, x: Any) -> float:
        """``V(x) = x^T P x``."""
        Pa = square(P, "P")
        xa = as_vector(x, Pa.shape[0], "x")
        return float(xa @ Pa @ xa)


def lyapunov_check(A: Any, P: Any, *, discrete: bool = False) -> LyapunovCertificate:
    """Check that ``V(x) = x^T P x`` is a Lyapunov function of ``x' = A x`` (or ``x+ = A x``).

    ``P > 0`` and ``A^T P + P A < 0`` (continuous) or ``A^T P A - P < 0`` (discrete).

    Args:
        A: system matrix (n x n).
        P: candidate (n x n), symmetric.
        discrete: discrete-time system.

    Raises:
        InvalidInputError: ``P`` is not symmetric.
    """
    A = square(A, "A")
    n = A.shape[0]
    P = square(P, "P", n)
    if np.max(np.abs(P - P.T)) > 1e-9 * max(1.0, float(np.max(np.abs(P)))):
        raise InvalidInputError("P must be symmetric for V(x) = x^T P x")
    D = A.T @ P @ A - P if discrete else A.T @ P + P @ A
    min_p = float(np.min(np.linalg.eigvalsh(P)))
    max_d = float(np.max(np.linalg.eigvalsh(0.5 * (D + D.T))))
    return LyapunovCertificate(
        valid=bool(min_p > 0.0 and max_d < 0.0),
        min_eigenvalue_P=min_p,
        max_eigenvalue_decrease=max_d,
        discrete=discrete,
    )
