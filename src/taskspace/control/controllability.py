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
from taskspace.control._linear import rank_tolerance, safe_norm, system
from taskspace.errors import InvalidInputError


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
        InvalidInputError: a power ``A^k B`` overflows float64 (the message names the first
            ``k``, the norms of ``A`` and ``B``, and suggests a scaling).
    """
    A, B = system(A, B)
    C, k = _krylov(A, B)
    if k:
        raise InvalidInputError(_overflow_message(A, B, k))
    return C


def _krylov(A: FloatArray, B: FloatArray) -> tuple[FloatArray, int]:
    """``([B, A B, ..., A^{n-1} B], 0)``, or ``(partial, k)`` at the first ``A^k B`` not finite."""
    blocks = [B]
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(1, A.shape[0]):
            blocks.append(A @ blocks[-1])
            if not np.isfinite(blocks[-1]).all():
                return np.hstack(blocks), k
    return np.hstack(blocks), 0


def _overflow_message(
    A: FloatArray, B: FloatArray, k: int, a_note: str = "", why: str = "", dual: bool = False
) -> str:
    """Why ``[B, AB, ..., A^(n-1)B]`` overflows at ``A^k B``, with the sizes and the remedy.

    ``dual``: the caller's pair is ``(A^T, C^T)`` of the observability matrix
    ``[C; CA; ...; CA^(n-1)]`` (the message names C and ``C A^k``; the 2-norms are the same).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        na, nb = _norm2(A), _norm2(B)
    n = A.shape[0]
    if dual:
        what, name = "the observability matrix [C; CA; ...; CA^(n-1)]", "C"
        power = "C A" if k == 1 else f"C A^{k}"
    else:
        what, name = "the controllability matrix [B, AB, ..., A^(n-1)B]", "B"
        power = "A B" if k == 1 else f"A^{k} B"
    grow = f"|{name}| |A|^k" if dual else f"|A|^k |{name}|"
    return (
        f"{what} overflows float64 (entries beyond 1.8e308) at {power}: |A|_2 = {na:.3g}{a_note}, "
        f"|{name}|_2 = {nb:.3g}, and its blocks grow like {grow} (k up to n - 1 = {n - 1}){why}; "
        f"rescale the state or the time unit so that A (and {name}) have moderate entries: "
        "A / 2^e, with 2^e a power of two near |A|, is exact and keeps the rank (the modes "
        "scale by 2^-e)"
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

    An ``A`` whose powers overflow float64 (a 3-state ``A`` near 1e200: ``A^2 B ~ 1e400``) is
    tested as ``2^-e A`` (``2^e`` just above ``max |A|``): exact, the column-normalized
    controllability matrix and the rank are the same, the modes are scaled back by ``2^e``. So
    is a tiny ``A`` (``max |A| < 2^-32``), whose powers would underflow (``A ~ 1e-200``:
    ``A^2 B ~ 1e-400`` is zero in float64).

    Args:
        A: system matrix (n x n).
        B: input matrix (n x m) (a vector is one input).
        tolerance: relative rank threshold in ``[0, 1)``; default ``max(n, m) n * eps * 1e3``.

    Raises:
        InvalidInputError: bad shapes or values, a tolerance outside ``[0, 1)`` (NaN made
            every pair uncontrollable), or the controllability matrix overflows even for
            ``2^-e A`` (``B`` too large, or ``A``'s entries span more than the floats' range);
            the message names the power ``A^k B``, the norms of ``A`` and ``B`` and the
            scaling to apply.
    """
    A, B = system(A, B)
    return _controllability(A, B, tolerance, dual=False)


def _controllability(
    A: FloatArray, B: FloatArray, tolerance: float | None, dual: bool
) -> ControllabilityResult:
    """:func:`controllability` of validated ``(A, B)``.

    ``dual``: the refusals name the observability matrix of ``(A^T, B^T)`` (see
    :func:`_overflow_message`).
    """
    n, m = B.shape
    user_tol = rank_tolerance(tolerance)
    tol = user_tol if user_tol is not None else max(n, m) * n * np.finfo(float).eps * 1e3
    C, k = _krylov(A, B)
    e = 0
    if k:  # the test on 2^-e A: the blocks A^j B scale by 2^-ej (exact), the modes by 2^-e
        A, e = _scaled(A, B, k, dual)
        C, k = _krylov(A, B)
        if k:  # (B too large)
            raise InvalidInputError(_overflow_message(A, B, k, f" (after A / 2^{e})", dual=dual))
    elif A.size and 0.0 < float(np.max(np.abs(A))) < _TINY_A:
        # a tiny A: its powers underflow (A^2 B ~ 1e-400 for A ~ 1e-200: a controllable pair
        # tested rank-deficient); 2^-e A with 2^e just above max |A| grows every entry (exact)
        scaled = _unit_scale(A)
        if scaled is not None:
            A, e = scaled
            C, _ = _krylov(A, B)
    with np.errstate(over="ignore", invalid="ignore"):
        # the two column blocks of the PBH test scaled separately (the rank is unchanged): one
        # common scale made B vanish next to an A near 1e300 (every mode "uncontrollable")
        scale_a = max(1.0, _norm2(A))
        scale_b = max(1.0, _norm2(B))
    rank, s = _rank(_unit_columns(C), tol)
    modes = []
    for lam in np.linalg.eigvals(A):
        pbh = np.hstack([(A - lam * np.eye(n)) / scale_a, B / scale_b])
        r, _ = _rank(pbh, tol)
        sv = np.linalg.svd(pbh, compute_uv=False)
        if r < n or (sv.size >= n and sv[n - 1] <= tol):
            modes.append(lam)
    found = np.asarray(modes, dtype=complex)
    if e:  # (a mode beyond the floats, |lambda| > 1.8e308 for A near it, becomes inf)
        with np.errstate(over="ignore", invalid="ignore"):
            found = np.ldexp(found.real, e) + 1j * np.ldexp(found.imag, e)
    return ControllabilityResult(
        controllable=rank == n,
        rank=rank,
        n=n,
        singular_values=s,
        uncontrollable_modes=found,
        tolerance=tol,
    )


_TINY_A = 2.0**-32
"""Below this largest entry of ``A``, the Krylov and PBH tests run on ``2^-e A`` (exact)."""


def _unit_columns(M: FloatArray) -> FloatArray:
    """``M`` with its nonzero columns scaled to unit 2-norm, its zero columns dropped.

    The range is the same; no column vanishes next to a larger one in the SVD's threshold
    (the powers ``A^k B`` can differ by orders of magnitude).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        norms = safe_norm(M, axis=0)  # np.linalg.norm was inf for entries ~1e300 (column -> 0)
    keep = norms > 0
    return np.asarray(M[:, keep] / norms[keep])


def _unit_scale(A: FloatArray) -> tuple[FloatArray, int] | None:
    """``(2^-e A, e)`` with ``2^e`` the power of two just above ``max |A|`` (exact).

    ``None`` when ``A`` is zero or the scaling would make a nonzero entry subnormal or zero.
    """
    top = float(np.max(np.abs(A))) if A.size else 0.0
    if top == 0.0:
        return None
    e = math.frexp(top)[1]
    As = np.ldexp(A, -e)
    nonzero = A != 0.0
    if float(np.min(np.abs(As[nonzero]))) < np.finfo(float).tiny:
        return None
    return As, e


def _scaled(A: FloatArray, B: FloatArray, k: int, dual: bool) -> tuple[FloatArray, int]:
    """``(2^-e A, e)`` with ``2^e`` the power of two just above ``max |A|``.

    Raises:
        InvalidInputError: the scaling would make a nonzero entry subnormal or zero (A spans
            more than the floats' range: the scaled test would not be exact).
    """
    scaled = _unit_scale(A)
    if scaled is None:
        top = float(np.max(np.abs(A)))
        e = math.frexp(top)[1]
        small = float(np.min(np.abs(A[A != 0.0])))
        raise InvalidInputError(
            _overflow_message(
                A,
                B,
                k,
                why=f"; A / 2^{e} would lose its smallest entries (|A_ij| from {small:.3g} to "
                f"{top:.3g}: more than the floats' range)",
                dual=dual,
            )
        )
    return scaled


def is_controllable(A: Any, B: Any, tolerance: float | None = None) -> bool:
    """``rank [B, A B, ..., A^{n-1} B] == n`` (see :func:`controllability`)."""
    return controllability(A, B, tolerance).controllable
