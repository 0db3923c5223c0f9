"""Validation helpers shared by the linear control-theory modules."""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_matrix, check_positive
from taskspace.errors import InvalidInputError, SolverError


def square(x: Any, name: str, n: int | None = None) -> FloatArray:
    """A finite square float matrix (n x n if given)."""
    arr = as_matrix(x, (n, n), name)
    if arr.shape[0] != arr.shape[1]:
        from taskspace.errors import ShapeError

        raise ShapeError(name, (arr.shape[0], arr.shape[0]), tuple(arr.shape))
    return arr


def system(A: Any, B: Any) -> tuple[FloatArray, FloatArray]:
    """``A`` (n x n) and ``B`` (n x m) with matching rows; a vector ``B`` is one column."""
    A = square(A, "A")
    n = A.shape[0]
    B_arr = as_float_array(B, "B")
    if B_arr.ndim == 1:
        B_arr = B_arr[:, None]
    B = as_matrix(B_arr, (n, None), "B")
    if n == 0 or B.shape[1] == 0:
        raise InvalidInputError(
            f"the system needs at least one state and one input; got A {A.shape}, B {B.shape}"
        )
    return A, B


def symmetric_psd(x: Any, name: str, n: int, *, definite: bool) -> FloatArray:
    """A symmetric positive (semi-)definite n x n matrix (scalars are ``x I``)."""
    arr = as_float_array(x, name)
    if arr.ndim == 0:
        arr = float(arr) * np.eye(n)
    arr = square(arr, name, n)
    scale = max(1.0, float(np.max(np.abs(arr)))) if arr.size else 1.0
    if np.max(np.abs(arr - arr.T)) > 1e-9 * scale:
        raise InvalidInputError(f"{name} must be symmetric")
    arr = 0.5 * (arr + arr.T)
    eig_min = float(np.min(np.linalg.eigvalsh(arr))) if n else 0.0
    if definite and eig_min <= 0.0:
        raise InvalidInputError(
            f"{name} must be positive definite, its smallest eigenvalue is {eig_min:.3g}"
        )
    if not definite and eig_min < -1e-10 * scale:
        raise InvalidInputError(
            f"{name} must be positive semidefinite, its smallest eigenvalue is {eig_min:.3g}"
        )
    return arr


def rank_tolerance(tolerance: Any, name: str = "tolerance") -> float | None:
    """A relative singular-value threshold in ``[0, 1)``, or ``None`` (the default).

    NaN made every rank 0 (every pair "uncontrollable"), a negative or >= 1 threshold every
    rank full or 0.
    """
    if tolerance is None:
        return None
    tol = check_positive(tolerance, name, strict=False)
    if tol >= 1.0:
        raise InvalidInputError(
            f"{name} is a relative singular-value threshold and must be in [0, 1), got {tol!r}"
        )
    return tol


def check_overflow(M: FloatArray, what: str, hint: str) -> FloatArray:
    """``M`` if finite; else ``InvalidInputError``: an intermediate overflowed float64."""
    if not np.all(np.isfinite(M)):
        raise InvalidInputError(f"{what} overflows float64 (entries beyond 1.8e308): {hint}")
    return M


def check_solution(P: FloatArray, what: str) -> FloatArray:
    """``P`` if finite; else ``SolverError`` (the solve overflowed or broke down)."""
    if not np.all(np.isfinite(P)):
        raise SolverError(
            f"{what} is not finite (the computation overflowed float64): rescale the problem "
            "(state and input units) so that A, B, Q and R have moderate entries"
        )
    return P


def safe_norm(X: Any, axis: int | None = None) -> Any:
    """Frobenius (or column, with ``axis=0``) norm without overflow or underflow.

    ``s |X / s|`` with ``s = max|X|`` where the plain norm would lose precision.

    ``np.linalg.norm`` squares the entries: a matrix with entries near 1e300 had norm inf, one
    whose entries are all below about 1e-154 norm 0 or a subnormal (a controllability column
    ``A^2 B`` near 1e-200 was dropped as zero).
    """
    X = np.asarray(X)
    if X.size == 0:
        return 0.0 if axis is None else np.zeros(X.shape[1 - axis])
    # the common case first (callers that may see huge entries hold np.errstate): the largest
    # entry between 1e-150 and the overflow, whose square is a normal float
    direct = np.linalg.norm(X, axis=axis)
    s = np.max(np.abs(X), axis=axis, keepdims=axis is not None)
    if np.isfinite(direct).all() and not ((s > 0) & (s < _TINY_NORM)).any():
        return float(direct) if axis is None else direct
    s = np.where(s > 0, s, 1.0)
    out = np.linalg.norm(X / s, axis=axis) * (s.ravel() if axis is not None else s)
    return float(out) if axis is None else out


_TINY_NORM = 1e-150
"""Below this largest entry, the squares in ``np.linalg.norm`` lose precision or vanish."""
