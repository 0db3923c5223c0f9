"""Quadratic programs as data.

``min_x 1/2 x^T H x + g^T x  s.t.  A x = b,  l <= C x <= u,  lb <= x <= ub``.
Row blocks carry labels so that a solver can name the constraints at fault.

Thread safety: :class:`QPProblem` and :class:`RowBlock` are plain mutable data, not locked: a
solver only reads a problem, so threads may solve one problem with their own solvers, but nobody
may modify it meanwhile.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taskspace._validation import FloatArray
from taskspace.errors import ShapeError
from taskspace.features.rows import INF

_max = np.maximum.reduce  # twice as fast as ndarray.max on small vectors

__all__ = ["INF", "QPProblem", "RowBlock"]


@dataclass
class RowBlock:
    """A named block of constraint rows ``[start, stop)`` of ``A``, ``C`` or the box."""

    name: str
    start: int
    stop: int


@dataclass
class QPProblem:
    """A QP: ``min 1/2 xᵀHx + gᵀx`` subject to ``Ax = b``, ``l <= Cx <= u``, ``lb <= x <= ub``.

    Attributes:
        H: (n, n) symmetric positive semi-definite Hessian.
        g: (n,) linear term.
        A, b: equality constraints (0 rows when absent).
        C, l, u: two-sided inequality constraints (0 rows when absent; +-INF for none).
        lb, ub: box bounds on ``x`` (+-INF for none).
        eq_blocks, in_blocks, box_blocks: names of the constraint row blocks.
        stacked: optionally, every constraint as ``lo <= G x <= hi`` (inequality rows,
            equality rows with ``lo = hi = b``, unit rows for the finite box bounds), kept
            consistent with the other arrays by the builder (e.g. ``C`` and ``A`` as views
            into ``G``): :meth:`is_feasible` is then one product and two reductions.
        convex: ``H`` is symmetric positive semi-definite by construction (``J^T W J`` with
            ``W >= 0``, plus a damping): set by taskspace's own builders, for which the solver
            skips :func:`~taskspace.qp.solver.check_convex` (one Cholesky factorization, 7-20
            us). Left ``False`` (the default), the solver checks ``H`` and refuses a
            non-convex QP, which no backend solves (they return a saddle or a maximum).
    """

    H: FloatArray
    g: FloatArray
    A: FloatArray
    b: FloatArray
    C: FloatArray
    l: FloatArray
    u: FloatArray
    lb: FloatArray
    ub: FloatArray
    eq_blocks: list[RowBlock] = field(default_factory=list)
    in_blocks: list[RowBlock] = field(default_factory=list)
    box_blocks: list[RowBlock] = field(default_factory=list)
    stacked: tuple[FloatArray, FloatArray, FloatArray] | None = None
    convex: bool = False

    @staticmethod
    def unconstrained(H: FloatArray, g: FloatArray) -> QPProblem:
        """A problem with no constraints."""
        n = g.shape[0]
        return QPProblem(
            H,
            g,
            np.zeros((0, n)),
            np.zeros(0),
            np.zeros((0, n)),
            np.zeros(0),
            np.zeros(0),
            np.full(n, -INF),
            np.full(n, INF),
        )

    @property
    def n(self) -> int:
        """Number of variables."""
        return int(self.g.shape[0])

    @property
    def n_eq(self) -> int:
        """Number of equality rows."""
        return int(self.A.shape[0])

    @property
    def n_in(self) -> int:
        """Number of inequality rows."""
        return int(self.C.shape[0])

    @property
    def has_box(self) -> bool:
        """Whether any box bound is finite."""
        return bool(np.any(self.lb > -INF) or np.any(self.ub < INF))

    def copy(self, *, objective: bool = True) -> QPProblem:
        """A copy that later in-place builds do not change (arrays and row blocks copied).

        ``objective=False`` leaves ``H`` out (an empty stand-in) and zeros ``g``: for what
        depends on the constraints only (a relaxed result's conflict set).
        """
        return QPProblem(
            self.H.copy() if objective else np.zeros((0, 0)),
            self.g.copy() if objective else np.zeros(self.n),
            self.A.copy(),
            self.b.copy(),
            self.C.copy(),
            self.l.copy(),
            self.u.copy(),
            self.lb.copy(),
            self.ub.copy(),
            [RowBlock(b.name, b.start, b.stop) for b in self.eq_blocks],
            [RowBlock(b.name, b.start, b.stop) for b in self.in_blocks],
            [RowBlock(b.name, b.start, b.stop) for b in self.box_blocks],
        )

    def structure(self) -> tuple[int, int, int]:
        """(n, n_eq, n_in): a backend workspace is reused while this does not change."""
        return self.n, self.n_eq, self.n_in

    def check(self) -> None:
        """Raise :class:`ShapeError` if the arrays do not fit together."""
        n = self.n
        expected = {
            "H": (n, n),
            "A": (self.b.shape[0], n),
            "C": (self.l.shape[0], n),
            "u": (self.l.shape[0],),
            "lb": (n,),
            "ub": (n,),
        }
        for name, shape in expected.items():
            actual = getattr(self, name).shape
            if actual != shape:
                raise ShapeError(f"QP {name}", shape, actual)

    def violations(self, x: FloatArray) -> dict[str, float]:
        """Largest violation of each named constraint block at ``x`` (positive = violated)."""
        out: dict[str, float] = {}
        if self.n_eq:
            r = np.abs(self.A @ x - self.b)
            for blk in self.eq_blocks or [RowBlock("equality", 0, self.n_eq)]:
                out[blk.name] = float(r[blk.start : blk.stop].max(initial=0.0))
        if self.n_in:
            Cx = self.C @ x
            r = np.maximum(self.l - Cx, Cx - self.u)
            for blk in self.in_blocks or [RowBlock("inequality", 0, self.n_in)]:
                out[blk.name] = float(r[blk.start : blk.stop].max(initial=0.0))
        r = np.maximum(self.lb - x, x - self.ub)
        for blk in self.box_blocks or [RowBlock("bounds", 0, self.n)]:
            out[blk.name] = max(
                out.get(blk.name, 0.0), float(r[blk.start : blk.stop].max(initial=0.0))
            )
        return out

    def max_violation(self, x: FloatArray) -> float:
        """Largest violation of any constraint at ``x`` (0 when feasible)."""
        if self.stacked is not None:
            G, lo, hi = self.stacked
            Gx = G.dot(x)
            if not Gx.shape[0]:
                return 0.0
            return max(0.0, float(_max(lo - Gx)), float(_max(Gx - hi)))
        worst = max(0.0, float((self.lb - x).max()), float((x - self.ub).max()))
        if self.C.shape[0]:
            Cx = self.C.dot(x)
            worst = max(worst, float((self.l - Cx).max()), float((Cx - self.u).max()))
        if self.A.shape[0]:
            worst = max(worst, float(np.abs(self.A.dot(x) - self.b).max()))
        return worst

    def is_feasible(self, x: FloatArray, tolerance: float = 1e-9) -> bool:
        """Whether ``x`` satisfies every constraint to ``tolerance``."""
        neg = -tolerance
        if self.stacked is not None:
            G, lo, hi = self.stacked
            Gx = G.dot(x)
            return bool((Gx - lo).min(initial=0.0) >= neg and (hi - Gx).min(initial=0.0) >= neg)
        if (x - self.lb).min() < neg or (self.ub - x).min() < neg:
            return False
        if self.C.shape[0]:
            Cx = self.C.dot(x)
            if (Cx - self.l).min() < neg or (self.u - Cx).min() < neg:
                return False
        if self.A.shape[0]:
            r = self.A.dot(x)
            r -= self.b
            if r.max() > tolerance or r.min() < neg:
                return False
        return True
