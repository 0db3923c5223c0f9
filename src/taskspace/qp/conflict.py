"""A minimal set of conflicting constraint blocks of an infeasible QP (deletion filter).

A relaxed result's ``culprits`` name every block its least-violating point violates: the
quadratic penalty spreads a conflict over all the blocks it touches, also blocks that are
only dragged along. :func:`conflicting_blocks` finds an irreducible infeasible subset of the
blocks (Chinneck's deletion filter): starting from every block, each block in turn is left
out when the remaining ones still conflict. The blocks kept conflict together and leaving any
one of them out makes the rest feasible (each was needed when it was tried, and the final set
is a subset of the set it was needed in). The objective ``H``, ``g`` plays no part.

Feasibility of a set of blocks is the phase-1 linear program ``min sum s`` subject to the
blocks' rows relaxed by ``s >= 0`` (``l - s <= C x <= u + s``, ``|A x - b| <= s``, ``lb - s
<= x <= ub + s``), solved by HiGHS (``scipy.optimize.linprog``): the set conflicts when the
least total violation exceeds ``tolerance``. One LP per block plus one: it runs only when a
caller asks (a relaxed result's :attr:`~taskspace.qp.QPResult.conflict`, on first access).

Thread safety: the function keeps its state local to the call.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import linprog
from scipy.sparse import csr_matrix, hstack

from taskspace._validation import FloatArray
from taskspace.qp.problem import INF, QPProblem

__all__ = ["conflicting_blocks"]


class _Unit:
    """The rows of one or more same-named blocks: left in or out together."""

    __slots__ = ("box", "eq", "ineq", "names")

    def __init__(self, name: str) -> None:
        self.names = [name]
        self.eq: list[int] = []
        self.ineq: list[int] = []
        self.box: list[int] = []


def _units(p: QPProblem) -> list[_Unit]:
    """The blocks as units, in the problem's order (equalities, inequalities, bounds).

    Rows in no named block form the units ``"equality"``, ``"inequality"``, ``"bounds"``;
    blocks of the same name are one unit; box blocks over common variables are one unit
    (their bounds are one merged ``lb``, ``ub``: they cannot be left out separately).
    """
    units: dict[str, _Unit] = {}

    def add(name: str, kind: str, rows: range | list[int]) -> None:
        unit = units.setdefault(name, _Unit(name))
        getattr(unit, kind).extend(rows)

    for kind, blocks, size, default in (
        ("eq", p.eq_blocks, p.n_eq, "equality"),
        ("ineq", p.in_blocks, p.n_in, "inequality"),
    ):
        covered = np.zeros(size, dtype=bool)
        for blk in blocks:
            add(blk.name, kind, range(blk.start, blk.stop))
            covered[blk.start : blk.stop] = True
        if not covered.all():
            add(default, kind, np.flatnonzero(~covered).tolist())
    # box: groups of overlapping blocks
    boxes: list[tuple[list[str], set[int]]] = []
    covered = np.zeros(p.n, dtype=bool)
    for blk in p.box_blocks:
        rows = set(range(blk.start, blk.stop))
        covered[blk.start : blk.stop] = True
        merged = [g for g in boxes if g[1] & rows]
        names = [blk.name]
        for g in merged:
            boxes.remove(g)
            names = g[0] + [n for n in names if n not in g[0]]
            rows |= g[1]
        boxes.append((names, rows))
    if not covered.all():
        boxes.append((["bounds"], set(np.flatnonzero(~covered).tolist())))
    for names, rows in boxes:
        unit = units.setdefault(names[0], _Unit(names[0]))
        for name in names[1:]:
            other = units.pop(name, None)  # a same-named equality or inequality block joins
            if other is not None:
                unit.eq += other.eq
                unit.ineq += other.ineq
            unit.names.append(name)
        unit.box.extend(sorted(rows))
    finite = (p.lb > -INF) | (p.ub < INF)
    out = []
    for unit in units.values():
        unit.box = [i for i in unit.box if finite[i]]
        if unit.eq or unit.ineq or unit.box:
            out.append(unit)
    return out


def _least_violation(p: QPProblem, units: list[_Unit]) -> float | None:
    """Least total violation ``min sum s`` of the units' rows (``None``: the LP failed)."""
    eq = sorted({i for unit in units for i in unit.eq})
    ineq = sorted({i for unit in units for i in unit.ineq})
    box = sorted({i for unit in units for i in unit.box})
    n = p.n
    rows: list[FloatArray] = []  # one-sided rows G x - s <= h, one slack per constraint row
    h: list[FloatArray] = []
    slack: list[int] = []
    k = 0

    def side(G: FloatArray, bound: FloatArray, sign: float, first: int) -> None:
        keep = np.flatnonzero(np.abs(bound) < INF)
        rows.append(sign * G[keep])
        h.append(sign * bound[keep])
        slack.extend((first + keep).tolist())

    if eq:
        A, b = p.A[eq], p.b[eq]
        side(A, b, 1.0, k)
        side(A, b, -1.0, k)
        k += len(eq)
    if ineq:
        C = p.C[ineq]
        side(C, p.u[ineq], 1.0, k)
        side(C, p.l[ineq], -1.0, k)
        k += len(ineq)
    if box:
        E = np.eye(n)[box]
        side(E, p.ub[box], 1.0, k)
        side(E, p.lb[box], -1.0, k)
        k += len(box)
    if not rows or k == 0:
        return 0.0
    G = np.vstack(rows)
    m = G.shape[0]
    S = csr_matrix((-np.ones(m), (np.arange(m), np.asarray(slack))), shape=(m, k))
    A_ub = hstack([csr_matrix(G), S]).tocsr()
    cost = np.concatenate([np.zeros(n), np.ones(k)])
    bounds = [(None, None)] * n + [(0.0, None)] * k
    res = linprog(cost, A_ub=A_ub, b_ub=np.concatenate(h), bounds=bounds, method="highs")
    if res.status != 0:
        return None
    return float(res.fun)


def conflicting_blocks(
    problem: QPProblem, tolerance: float = 1e-6, prefer: Sequence[str] = ()
) -> list[str]:
    """Names of an irreducible set of conflicting constraint blocks (deletion filter).

    Args:
        problem: the QP; its blocks (``eq_blocks``, ``in_blocks``, ``box_blocks``) are the
            units left out or kept (see the module docstring for unnamed rows and box blocks
            over common variables, which are reported together).
        tolerance: the blocks conflict when their least total violation (sum over rows, in
            the rows' own units) exceeds this.
        prefer: names of blocks tried last (a relaxed result's culprits): the other blocks
            are left out first, so the set found lies within ``prefer`` whenever the blocks
            of ``prefer`` conflict by themselves (a problem can have several minimal
            conflicts).

    Returns:
        The names in the problem's block order; empty when the constraints do not conflict
        (or a feasibility LP failed: no claim is made then).
    """
    units = _units(problem)
    first = _least_violation(problem, units)
    if first is None or first <= tolerance:
        return []
    kept = list(units)
    preferred = set(prefer)
    for unit in sorted(units, key=lambda u: any(n in preferred for n in u.names)):
        rest = [u for u in kept if u is not unit]
        v = _least_violation(problem, rest)
        if v is None:
            return []
        if v > tolerance:
            kept = rest  # still conflicting without it: not needed
    return [name for unit in kept for name in unit.names]
