"""Symmetric block-banded matrices: the pseudo-Hessian of path optimization (slide 4:4).

A path cost ``f(q_1:T) = sum_t |Psi_t(q_t-k, .., q_t)|^2 + sum_t |Phi_t(q_t)|^2`` couples each
configuration only with its ``k`` neighbours on either side, so the Gauss-Newton matrix
``H = J^T J`` (``T nv x T nv``) is zero outside ``k`` block diagonals: ``H_st = 0`` for
``|s - t| > k``. It is stored in LAPACK's lower band format with ``(k + 1) nv`` rows,
``ab[i - j, j] = H[i, j]`` for ``0 <= i - j < (k + 1) nv``, so memory and the Cholesky
factorization cost ``O(T nv ((k + 1) nv)^2)``: linear in the number of time slices ``T``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError, ShapeError, SolverError


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
        b = self.block_size
        rows, cols = np.tril_indices(b)  # (a, c) with a >= c inside one block
        self._block_rows = rows
        self._block_cols = cols
        # entry (a, c) of block t goes to ab[a - c, t b + c]
        offsets = np.arange(self.blocks)[:, None] * b
        self._diag_r = np.broadcast_to(rows - cols, (self.blocks, rows.size)).ravel()
        self._diag_c = (offsets + cols[None, :]).ravel()

    @property
    def bandwidth(self) -> int:
        """Rows of the band storage, ``(k + 1) b`` (lower bandwidth + 1)."""
        return (self.block_bandwidth + 1) * self.block_size

    def copy(self) -> SymmetricBlockBanded:
        """A deep copy."""
        out = SymmetricBlockBanded(self.blocks, self.block_size, self.block_bandwidth)
        out.ab[:] = self.ab
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
        """``A x`` from the band storage (``O(n b^2 k)``)."""
        ab, n = self.ab, self.size
        y = ab[0] * x
        for o in range(1, self.bandwidth):
            d = ab[o, : n - o]
            y[o:] += d * x[: n - o]
            y[: n - o] += d * x[o:]
        return y

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
        """Solve ``A x = rhs`` by a banded Cholesky factorization (``scipy.linalg``).

        Raises:
            SolverError: ``A`` is not (numerically) positive definite.
        """
        try:
            factor = scipy.linalg.cholesky_banded(self.ab, lower=True, check_finite=False)
        except np.linalg.LinAlgError as exc:
            raise SolverError(
                f"banded Cholesky failed ({exc}): the pseudo-Hessian is not positive definite; "
                "increase the damping"
            ) from exc
        return np.asarray(
            scipy.linalg.cho_solve_banded((factor, True), rhs, check_finite=False), dtype=float
        )
