"""Controllability of a linear system ``x' = A x + B u`` (or ``x+ = A x + B u``).

Kalman's test: the pair ``(A, B)`` is controllable iff the controllability matrix
``C = [B, A B, A^2 B, ..., A^{n-1} B]`` has rank ``n``. The uncontrollable modes are found
with the Popov-Belevitch-Hautus test: an eigenvalue ``lambda`` of ``A`` is uncontrollable iff
``rank [A - lambda I, B] < n``. A pair is stabilizable iff every uncontrollable mode is
stable (``Re lambda < 0``, or ``|lambda| < 1`` in discrete time).

Thread safety: the functions keep their state local to the call; a :class:`ControllabilityResult`
is plain result data (arrays), not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray
from taskspace.control._linear import check_overflow, rank_tolerance, safe_norm, system


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
    """``[B, A B, ..., A^{n-1} B]`` (n x n m).

    Raises:
        InvalidInputError: a power ``A^k B`` overflows float64.
    """
    A, B = system(A, B)
    n = A.shape[0]
    blocks = [B]
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(n - 1):
            blocks.append(A @ blocks[-1])
    return check_overflow(
        np.hstack(blocks),
        "the controllability matrix [B, AB, ..., A^(n-1)B]",
        "rescale the state or the time unit so that A has moderate entries",
    )


def _norm2(M: FloatArray) -> float:
    """Spectral norm without overflow (``np.linalg.norm(M, 2)`` was inf near 1e300)."""
    direct = float(np.linalg.norm(M, 2)) if M.size else 0.0  # caller holds np.errstate
    if math.isfinite(direct):
        return direct
    s = float(np.max(np.abs(M)))
    return s * float(np.linalg.norm(M / s, 2)) if s > 0 else 0.0


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
        tolerance: relative rank threshold in ``[0, 1)``; default ``max(n, m) n * eps * 1e3``.

    Raises:
        InvalidInputError: bad shapes or values, a tolerance outside ``[0, 1)`` (NaN made
            every pair uncontrollable), or the controllability matrix overflows.
    """
    A, B = system(A, B)
    n, m = B.shape
    user_tol = rank_tolerance(tolerance)
    tol = user_tol if user_tol is not None else max(n, m) * n * np.finfo(float).eps * 1e3
    C = controllability_matrix(A, B)
    with np.errstate(over="ignore", invalid="ignore"):
        norms = safe_norm(C, axis=0)  # np.linalg.norm was inf for entries ~1e300 (column -> 0)
        # the two column blocks of the PBH test scaled separately (the rank is unchanged): one
        # common scale made B vanish next to an A near 1e300 (every mode "uncontrollable")
        scale_a = max(1.0, _norm2(A))
        scale_b = max(1.0, _norm2(B))
    Cn = C[:, norms > 0] / norms[norms > 0]
    rank, s = _rank(Cn, tol)
    modes = []
    for lam in np.linalg.eigvals(A):
        pbh = np.hstack([(A - lam * np.eye(n)) / scale_a, B / scale_b])
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
