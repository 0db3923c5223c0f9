"""Symmetric block-banded matrices: the pseudo-Hessian of path optimization (slide 4:4).

A path cost ``f(q_1:T) = sum_t |Psi_t(q_t-k, .., q_t)|^2 + sum_t |Phi_t(q_t)|^2`` couples each
configuration only with its ``k`` neighbours on either side, so the Gauss-Newton matrix
``H = J^T J`` (``T nv x T nv``) is zero outside ``k`` block diagonals: ``H_st = 0`` for
``|s - t| > k``. It is stored in LAPACK's lower band format with ``(k + 1) nv`` rows,
``ab[i - j, j] = H[i, j]`` for ``0 <= i - j < (k + 1) nv``, so memory and the Cholesky
factorization cost ``O(T nv ((k + 1) nv)^2)``: linear in the number of time slices ``T``.

Thread safety: a :class:`SymmetricBlockBanded` is a mutable matrix (its ``add_*`` methods
change it in place) and is not locked: one matrix per thread, or no writes while other threads
read it. The cached index helpers (``functools.lru_cache``) are safe to call from several
threads.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import numpy.typing as npt
from scipy.linalg import blas, lapack

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError, ShapeError, SolverError

IntArray = npt.NDArray[np.intp]


@lru_cache(maxsize=64)
def _block_indices(blocks: int, b: int) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """Index arrays scattering the lower halves of ``blocks`` diagonal blocks into the band.

    Entry (a, c) with a >= c of block t goes to ``ab[a - c, t b + c]``. Returns the rows
    ``a`` and columns ``c`` inside a block and the band row and column of every entry of
    every block (read-only: shared by all matrices of the same structure).
    """
    rows, cols = (np.asarray(x, dtype=np.intp) for x in np.tril_indices(b))
    offsets = np.arange(blocks, dtype=np.intp)[:, None] * b
    diag_r = np.tile(rows - cols, blocks)
    diag_c = (offsets + cols[None, :]).ravel()
    for arr in (rows, cols, diag_r, diag_c):
        arr.flags.writeable = False
    return rows, cols, diag_r, diag_c


class SymmetricBlockBanded:
    """Symmetric ``(n b) x (n b)`` matrix: ``n`` blocks of size ``b``, block bandwidth ``k``.

    Only the lower band is stored (``ab``, shape ``((k + 1) b, n b)``, LAPACK lower storage:
    ``ab[i - j, j] = A[i, j]`` for ``i >= j``); ``A_st = 0`` for blocks with ``|s - t| > k``.

    Args:
        blocks: number of diagonal blocks ``n`` (time slices).
        block_size: size ``b`` of a block (``nv``).
        block_bandwidth: number ``k`` of off-diagonal blocks on each side (control order).
    """

    def __init__(self, blocks: int, block_size: int, block_bandwidth: int) -> None:
        if blocks < 1 or block_size < 1 or block_bandwidth < 0:
            raise InvalidInputError(
                f"block-banded matrix needs blocks >= 1, block_size >= 1, block_bandwidth >= 0; "
                f"got {blocks}, {block_size}, {block_bandwidth}"
            )
        self.blocks = int(blocks)
        self.block_size = int(block_size)
        self.block_bandwidth = int(block_bandwidth)
        self.size = self.blocks * self.block_size
        self.ab = np.zeros((self.bandwidth, self.size))
        self._block_rows, self._block_cols, self._diag_r, self._diag_c = _block_indices(
            self.blocks, self.block_size
        )

    @property
    def bandwidth(self) -> int:
        """Rows of the band storage, ``(k + 1) b`` (lower bandwidth + 1)."""
        return (self.block_bandwidth + 1) * self.block_size

    def copy(self) -> SymmetricBlockBanded:
        """A deep copy (the band storage is copied; index tables are shared)."""
        out = object.__new__(SymmetricBlockBanded)
        out.__dict__.update(self.__dict__)
        out.ab = self.ab.copy()
        return out

    def fill(self, other: SymmetricBlockBanded) -> None:
        """Overwrite with the entries of ``other`` (same structure)."""
        if other.ab.shape != self.ab.shape:
            raise ShapeError("band storage", self.ab.shape, other.ab.shape)
        np.copyto(self.ab, other.ab)

    def add_diagonal_blocks(self, blocks: FloatArray) -> None:
        """``A_tt += B_t`` for symmetric blocks ``B`` of shape (n, b, b) (lower halves read)."""
        if blocks.shape != (self.blocks, self.block_size, self.block_size):
            raise ShapeError(
                "diagonal blocks", (self.blocks, self.block_size, self.block_size), blocks.shape
            )
        self.ab[self._diag_r, self._diag_c] += blocks[:, self._block_rows, self._block_cols].ravel()

    def add_diagonal(self, values: FloatArray | float) -> None:
        """``A_ii += values_i`` (a scalar or a vector of size ``n b``)."""
        self.ab[0] += values

    def add_scalar_band_kron(self, scalar_band: FloatArray) -> None:
        """``A += S kron I_b`` for a symmetric banded ``n x n`` matrix ``S``.

        Args:
            scalar_band: lower band storage of ``S``, shape (k + 1, n): ``S[s + o, s]`` in
                ``scalar_band[o, s]``.
        """
        b = self.block_size
        if scalar_band.shape != (self.block_bandwidth + 1, self.blocks):
            raise ShapeError(
                "scalar band", (self.block_bandwidth + 1, self.blocks), scalar_band.shape
            )
        # entry (s b + a, s' b + a) -> ab[(s - s') b, s' b + a]
        self.ab[::b] += np.repeat(scalar_band, b, axis=1)

    def matvec(self, x: FloatArray) -> FloatArray:
        """``A x`` from the band storage (``O(n b^2 k)``, BLAS ``dsbmv``)."""
        if x.shape != (self.size,):
            raise ShapeError("vector", (self.size,), x.shape)
        y = blas.dsbmv(self.bandwidth - 1, 1.0, self.ab, np.asarray(x, dtype=float), lower=1)
        return np.asarray(y, dtype=float)

    def to_dense(self) -> FloatArray:
        """The full matrix (for tests and inspection only: ``O((n b)^2)`` memory)."""
        n = self.size
        A = np.zeros((n, n))
        for o in range(self.bandwidth):
            idx = np.arange(n - o)
            A[idx + o, idx] = self.ab[o, : n - o]
            A[idx, idx + o] = self.ab[o, : n - o]
        return A

    def solve(self, rhs: FloatArray) -> FloatArray:
        """Solve ``A x = rhs`` by a banded Cholesky factorization (LAPACK ``dpbtrf``, ``dpbtrs``).

        Raises:
            SolverError: ``A`` is not (numerically) positive definite.
        """
        factor, info = lapack.dpbtrf(self.ab, lower=1)
        if info != 0:
            reason = f"leading minor {info} is not positive" if info > 0 else f"argument {-info}"
            raise SolverError(
                f"banded Cholesky failed ({reason}): the pseudo-Hessian is not positive "
                "definite; increase the damping"
            )
        b = np.asarray(rhs, dtype=float)
        if b.shape[0] != self.size:
            raise ShapeError("right-hand side", (self.size,), b.shape)
        x, info = lapack.dpbtrs(factor, b, lower=1)
        if info != 0:  # pragma: no cover - only for invalid arguments
            raise SolverError(f"banded Cholesky solve failed (LAPACK info {info})")
        return np.asarray(x, dtype=float)
