"""Controllability of a linear system ``x' = A x + B u`` (or ``x+ = A x + B u``).

Kalman's test: the pair ``(A, B)`` is controllable iff the controllability matrix
``C = [B, A B, A^2 B, ..., A^{n-1} B]`` has rank ``n``. The uncontrollable modes are found
with the Popov-Belevitch-Hautus test: an eigenvalue ``lambda`` of ``A`` is uncontrollable iff
``rank [A - lambda I, B] < n``. A pair is stabilizable iff every uncontrollable mode is
stable (``Re lambda < 0``, or ``|lambda| < 1`` in discrete time).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray
from taskspace.control._linear import system


@dataclass
class ControllabilityResult:
    """Result of :func:`controllability`.

    Attributes:
        controllable: ``rank C == n``.
        rank: numerical rank of the controllability matrix.
        n: state dimension.
        singular_values: of the column-normalized controllability matrix.
        uncontrollable_modes: eigenvalues of ``A`` failing the PBH test (complex).
        tolerance: relative singular-value threshold used for the ranks.
    """

    controllable: bool
    rank: int
    n: int
    singular_values: FloatArray
    uncontrollable_modes: np.ndarray
    tolerance: float

    def stabilizable(self, *, discrete: bool = False) -> bool:
        """Every uncontrollable mode is stable (continuous or discrete time)."""
        modes = self.uncontrollable_modes
        if discrete:
            return bool(np.all(np.abs(modes) < 1.0))
        return bool(np.all(modes.real < 0.0))


def controllability_matrix(A: Any, B: Any) -> FloatArray:
    """``[B, A B, ..., A^{n-1} B]`` (n x n m)."""
    A, B = system(A, B)
    n = A.shape[0]
    blocks = [B]
    for _ in range(n - 1):
        blocks.append(A @ blocks[-1])
    return np.hstack(blocks)


def _rank(M: FloatArray, tol: float) -> tuple[int, FloatArray]:
    if M.size == 0:
        return 0, np.zeros(0)
    s = np.asarray(np.linalg.svd(M, compute_uv=False), dtype=np.float64)
    if s.size == 0 or s[0] == 0.0:
        return 0, s
    return int(np.sum(s > tol * s[0])), s


def controllability(A: Any, B: Any, tolerance: float | None = None) -> ControllabilityResult:
    """Kalman rank test and PBH uncontrollable modes of ``(A, B)``.

    The columns of the controllability matrix are normalized before the SVD (the powers of
    ``A`` can differ by orders of magnitude); singular values below ``tolerance`` times the
    largest count as zero.

    Args:
        A: system matrix (n x n).
        B: input matrix (n x m) (a vector is one input).
        tolerance: relative rank threshold; default ``max(n, m) n * eps * 1e3``.
    """
    A, B = system(A, B)
    n, m = B.shape
    tol = float(tolerance) if tolerance is not None else max(n, m) * n * np.finfo(float).eps * 1e3
    C = controllability_matrix(A, B)
    norms = np.linalg.norm(C, axis=0)
    Cn = C[:, norms > 0] / norms[norms > 0]
    rank, s = _rank(Cn, tol)
    modes = []
    scale = max(1.0, float(np.linalg.norm(A, 2)), float(np.linalg.norm(B, 2)))
    for lam in np.linalg.eigvals(A):
        pbh = np.hstack([A - lam * np.eye(n), B]) / scale
        r, _ = _rank(pbh, tol)
        sv = np.linalg.svd(pbh, compute_uv=False)
        if r < n or (sv.size >= n and sv[n - 1] <= tol):
            modes.append(lam)
    return ControllabilityResult(
        controllable=rank == n,
        rank=rank,
        n=n,
        singular_values=s,
        uncontrollable_modes=np.asarray(modes, dtype=complex),
        tolerance=tol,
    )


def is_controllable(A: Any, B: Any, tolerance: float | None = None) -> bool:
    """``rank [B, A B, ..., A^{n-1} B] == n`` (see :func:`controllability`)."""
    return controllability(A, B, tolerance).controllable
