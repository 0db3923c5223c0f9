"""Observability of ``x' = A x + B u, y = C x`` and the Kalman decomposition.

Kalman's test: ``(A, C)`` is observable iff the observability matrix
``O = [C; C A; C A^2; ...; C A^{n-1}]`` has rank ``n``. By duality, ``(A, C)`` is observable
iff ``(A^T, C^T)`` is controllable, so the unobservable modes are the PBH-uncontrollable modes
of ``(A^T, C^T)``; the pair is detectable iff every unobservable mode is stable.

The Kalman decomposition splits the state space into four parts: controllable and observable
(``co``), controllable and unobservable (``cu``), uncontrollable and observable (``uo``),
uncontrollable and unobservable (``uu``). In the coordinates ``x = T z`` with
``T = [T_co, T_cu, T_uo, T_uu]``

``T^-1 A T = [[A11, 0, A13, 0], [A21, A22, A23, A24], [0, 0, A33, 0], [0, 0, A43, A44]]``,
``T^-1 B = [B1; B2; 0; 0]``, ``C T = [C1, 0, C3, 0]``,

and the transfer function ``C (sI - A)^-1 B = C1 (sI - A11)^-1 B1`` only sees the ``co`` part.

Thread safety: the functions keep their state local to the call; :class:`ObservabilityResult` and
:class:`KalmanDecomposition` are plain result data (arrays) whose methods only read them, not
locked: do not modify them while another thread reads them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from taskspace._validation import FloatArray, as_float_array, as_matrix
from taskspace.control._linear import rank_tolerance, square, system
from taskspace.control.controllability import (
    _controllability,
    _krylov,
    _overflow_message,
    _unit_columns,
    _unit_scale,
)
from taskspace.errors import InvalidInputError


def _output(A: Any, C: Any) -> tuple[FloatArray, FloatArray]:
    A = square(A, "A")
    n = A.shape[0]
    C_arr = as_float_array(C, "C")  # refuses text, None, complex (was truncated silently)
    if C_arr.ndim == 1:
        C_arr = C_arr[None, :]
    return A, as_matrix(C_arr, (None, n), "C")


def observability_matrix(A: Any, C: Any) -> FloatArray:
    """``[C; C A; ...; C A^{n-1}]`` (n p x n); a vector ``C`` is one output row.

    The transpose of the controllability matrix of ``(A^T, C^T)`` (duality).

    Raises:
        InvalidInputError: a power ``C A^k`` overflows float64 (the message names the first
            ``k``, the norms of ``A`` and ``C``, and suggests a scaling).
    """
    A, C = _output(A, C)
    O, k = _krylov(A.T, C.T)
    if k:
        raise InvalidInputError(_overflow_message(A.T, C.T, k, dual=True))
    return np.ascontiguousarray(O.T)


@dataclass
class ObservabilityResult:
    """Result of :func:`observability`.

    Attributes:
        observable: ``rank O == n``.
        rank: numerical rank of the observability matrix.
        n: state dimension.
        singular_values: of the row-normalized observability matrix.
        unobservable_modes: eigenvalues of ``A`` failing the PBH test
            ``rank [A - lambda I; C] < n`` (complex).
        tolerance: relative singular-value threshold used for the ranks.
    """

    observable: bool
    rank: int
    n: int
    singular_values: FloatArray
    unobservable_modes: np.ndarray
    tolerance: float

    def detectable(self, *, discrete: bool = False) -> bool:
        """Every unobservable mode is stable (continuous or discrete time)."""
        modes = self.unobservable_modes
        if discrete:
            return bool(np.all(np.abs(modes) < 1.0))
        return bool(np.all(modes.real < 0.0))


def observability(A: Any, C: Any, tolerance: float | None = None) -> ObservabilityResult:
    """Kalman rank test and PBH unobservable modes of ``(A, C)`` (dual of controllability).

    Args:
        A: system matrix (n x n).
        C: output matrix (p x n) (a vector is one output).
        tolerance: relative rank threshold (see :func:`controllability`).

    An ``A`` whose powers overflow float64 is tested as ``2^-e A`` (exact; see
    :func:`controllability`, applied to ``(A^T, C^T)``).

    Raises:
        InvalidInputError: bad shapes or values, a tolerance outside ``[0, 1)``, or the
            observability matrix overflows even for ``2^-e A``; the message names the power
            ``C A^k``, the norms of ``A`` and ``C`` and the scaling to apply.
    """
    A, C = _output(A, C)
    dual = _controllability(A.T, C.T, tolerance, dual=True)
    return ObservabilityResult(
        observable=dual.controllable,
        rank=dual.rank,
        n=dual.n,
        singular_values=dual.singular_values,
        unobservable_modes=dual.uncontrollable_modes,
        tolerance=dual.tolerance,
    )


def is_observable(A: Any, C: Any, tolerance: float | None = None) -> bool:
    """``rank [C; C A; ...; C A^{n-1}] == n`` (see :func:`observability`)."""
    return observability(A, C, tolerance).observable


@dataclass
class KalmanDecomposition:
    """Result of :func:`kalman_decomposition`: ``x = T z``, ``z = [z_co, z_cu, z_uo, z_uu]``.

    Attributes:
        T: change of basis (n x n), columns ``[T_co, T_cu, T_uo, T_uu]``.
        A: ``T^-1 A T`` (n x n), with the zero blocks of the module docstring.
        B: ``T^-1 B`` (n x m).
        C: ``C T`` (p x n).
        sizes: dimensions ``(n_co, n_cu, n_uo, n_uu)``.
    """

    T: FloatArray
    A: FloatArray
    B: FloatArray
    C: FloatArray
    sizes: tuple[int, int, int, int]

    def part(self, name: str) -> slice:
        """Slice of the part ``"co"``, ``"cu"``, ``"uo"`` or ``"uu"`` in ``z``."""
        names = ("co", "cu", "uo", "uu")
        if name not in names:
            from taskspace.errors import UnknownNameError

            raise UnknownNameError("Kalman decomposition part", name, names)
        i = names.index(name)
        start = sum(self.sizes[:i])
        return slice(start, start + self.sizes[i])

    def minimal(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The controllable and observable realization ``(A11, B1, C1)``."""
        s = self.part("co")
        return self.A[s, s], self.B[s], self.C[:, s]


def _range(M: FloatArray, tol: float) -> FloatArray:
    if M.size == 0:
        return np.zeros((M.shape[0], 0))
    return np.asarray(sla.orth(M, rcond=tol), dtype=float)


def _null(M: FloatArray, n: int, tol: float) -> FloatArray:
    if M.size == 0:
        return np.eye(n)
    return np.asarray(sla.null_space(M, rcond=tol), dtype=float)


def _null_abs(M: FloatArray, n: int, atol: float) -> FloatArray:
    """Null space of ``M`` with an absolute threshold on its singular values.

    For stacks of projector complements (``I - R R^T``: singular values 0 or the sines of
    principal angles) a threshold relative to the largest singular value fails when the
    projector is zero up to rounding (``R`` the whole space: every singular value ~1e-16 kept,
    the null space empty).
    """
    if M.size == 0:
        return np.eye(n)
    _, s, vh = np.linalg.svd(M, full_matrices=True)
    rank = int(np.sum(s > atol))
    return np.asarray(vh[rank:].T, dtype=float)


def kalman_decomposition(
    A: Any, B: Any, C: Any, tolerance: float | None = None
) -> KalmanDecomposition:
    """Kalman's canonical decomposition of ``(A, B, C)`` into the four parts co, cu, uo, uu.

    Subspaces (orthonormal bases from SVDs): ``R`` = range of the controllability matrix,
    ``N`` = null space of the observability matrix; ``T_cu`` spans ``R ∩ N``, ``T_co`` its
    orthogonal complement within ``R``, ``T_uu`` the complement of ``R ∩ N`` within ``N``, and
    ``T_uo`` the orthogonal complement of all three.

    The subspaces are those of ``2^-e A`` (``2^e`` the power of two just above ``max |A|``: an
    exact scaling, and the subspaces of ``s A`` are those of ``A`` for every ``s != 0``; ``A``
    itself when its entries span more than the floats' range and the scaling would not be
    exact), from
    the controllability matrix with its columns normalized and the observability matrix with
    its rows normalized (the powers ``A^k`` can differ by orders of magnitude); the blocks
    ``A``, ``B``, ``C`` of the result are those of the given ``A``.

    Args:
        A: (n x n); B: (n x m); C: (p x n).
        tolerance: relative rank threshold of the SVDs in ``[0, 1)``; default
            ``n max(m, p) eps 1e3``.

    Raises:
        InvalidInputError: bad shapes or values, or ``B`` or ``C`` so large that the
            controllability or observability matrix of ``2^-e A`` overflows.
    """
    A, B = system(A, B)
    A, C = _output(A, C)
    n, m = B.shape
    p = C.shape[0]
    user_tol = rank_tolerance(tolerance)
    tol = user_tol if user_tol is not None else max(n, m, p) * n * np.finfo(float).eps * 1e3
    scaled = _unit_scale(A)  # (None: A zero, or spanning more than the floats' range)
    unit_a = A if scaled is None else scaled[0]
    note = " (after scaling A to max |A| < 1)" if scaled is not None else ""
    Ctrb, k = _krylov(unit_a, B)
    if k:
        raise InvalidInputError(_overflow_message(unit_a, B, k, note))
    Obsv_t, k = _krylov(unit_a.T, C.T)
    if k:
        raise InvalidInputError(_overflow_message(unit_a.T, C.T, k, note, dual=True))
    R = _range(_unit_columns(Ctrb), tol)
    N = _null(_unit_columns(Obsv_t).T, n, tol)
    eye = np.eye(n)
    # R ∩ N = null([I - R R^T; I - N N^T]).
    # (absolute thresholds: the stacks' singular values are sines of principal angles, or 0)
    atol = 1e3 * n * np.finfo(float).eps
    cu = _null_abs(np.vstack([eye - R @ R.T, eye - N @ N.T]), n, atol)
    co = _null_abs(np.vstack([eye - R @ R.T, cu.T]), n, atol)
    uu = _null_abs(np.vstack([eye - N @ N.T, cu.T]), n, atol)
    spanned = np.hstack([co, cu, uu])
    uo = _null_abs(spanned.T, n, atol) if spanned.shape[1] else np.eye(n)
    T = np.hstack([co, cu, uo, uu])
    if T.shape[1] != n:
        from taskspace.errors import SolverError

        raise SolverError(
            f"Kalman decomposition: the subspaces span {T.shape[1]} dimensions instead of n = {n} "
            "(ill-conditioned controllability/observability matrices); pass a larger tolerance"
        )
    Tinv = np.linalg.inv(T)
    return KalmanDecomposition(
        T=T,
        A=Tinv @ A @ T,
        B=Tinv @ B,
        C=C @ T,
        sizes=(co.shape[1], cu.shape[1], uo.shape[1], uu.shape[1]),
    )
