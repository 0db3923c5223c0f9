"""High-precision DARE reference for the tests: Newton-Hewer steps in 50-digit decimals.

Independent of taskspace and of LAPACK: plain Gaussian elimination on the Kronecker form
of each Stein equation, in :mod:`decimal` arithmetic.
"""

from __future__ import annotations

from decimal import Decimal, localcontext
from typing import Any

import numpy as np

Mat = list[list[Decimal]]


def _mat(X: Any) -> Mat:
    return [[Decimal(float(v)) for v in row] for row in np.atleast_2d(np.asarray(X, float))]


def _mul(X: Mat, Y: Mat) -> Mat:
    cols = list(zip(*Y))
    return [[sum((a * b for a, b in zip(row, col)), Decimal(0)) for col in cols] for row in X]


def _t(X: Mat) -> Mat:
    return [list(r) for r in zip(*X)]


def _add(X: Mat, Y: Mat, sign: int = 1) -> Mat:
    return [[a + sign * b for a, b in zip(r, q)] for r, q in zip(X, Y)]


def _solve(M: Mat, rhs: Mat) -> Mat:
    """Gauss-Jordan elimination with partial pivoting: ``M X = rhs``."""
    n = len(M)
    W = [row[:] + r[:] for row, r in zip(M, rhs)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(W[r][c]))
        W[c], W[p] = W[p], W[c]
        for r in range(n):
            if r != c:
                f = W[r][c] / W[c][c]
                W[r] = [a - f * b for a, b in zip(W[r], W[c])]
    return [[W[i][j] / W[i][i] for j in range(n, len(W[0]))] for i in range(n)]


def dare_reference(A: Any, B: Any, Q: Any, R: Any, P0: Any, steps: int = 8) -> np.ndarray:
    """Stabilizing DARE solution by Newton-Hewer from ``P0`` (any good float estimate)."""
    with localcontext() as ctx:
        ctx.prec = 50
        Ad, Bd, Qd, Rd, P = map(_mat, (A, B, Q, R, P0))
        n = len(Ad)
        for _ in range(steps):
            BtP = _mul(_t(Bd), P)
            K = _solve(_add(Rd, _mul(BtP, Bd)), _mul(BtP, Ad))
            Ak = _add(Ad, _mul(Bd, K), -1)
            rhs = _add(Qd, _mul(_mul(_t(K), Rd), K))
            # Ak^T P Ak - P + rhs = 0  <=>  (I - Ak^T (x) Ak^T) vec(P) = vec(rhs)
            M = [[Decimal(0)] * (n * n) for _ in range(n * n)]
            for i in range(n):
                for j in range(n):
                    row = i * n + j
                    M[row][row] += 1
                    for k in range(n):
                        for m in range(n):
                            M[row][k * n + m] -= Ak[k][i] * Ak[m][j]
            vec = _solve(M, [[rhs[i][j]] for i in range(n) for j in range(n)])
            P = [[vec[i * n + j][0] for j in range(n)] for i in range(n)]
        return np.array([[float(v) for v in r] for r in P])
