"""A relaxed QP's ``conflict``: an irreducible set of conflicting blocks (deletion filter).

A relaxed result's ``culprits`` name every block the least-violating point violates: the
penalty spreads a conflict over blocks that are only dragged along (the weighted
inverse-dynamics QP on a humanoid whose ankles are outside their range named all six of its
blocks). ``conflict`` names a minimal conflicting subset. The reference is an enumeration of
every subset of blocks of small 2-D problems, each subset's feasibility decided by vertex
enumeration (a bounded polygon is non-empty iff one of the pairwise intersections of its
boundary lines satisfies every row).
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions
from taskspace.model import Robot
from taskspace.qp import QPProblem, QPSolver, QPStatus, RowBlock
from taskspace.qp.conflict import conflicting_blocks
from tests.control.test_control_no_hang import flat_footed_humanoid

BIG = 100.0  # every scene lies in |x| <= 10: this frame only bounds the polygons


def _scene(seed: int):  # type: ignore[no-untyped-def]
    """2-D half-plane blocks (1-2 rows), sometimes a line, and a box block."""
    rng = np.random.default_rng(seed)
    rows, lo, hi, blocks = [], [], [], []
    for k in range(int(rng.integers(3, 6))):
        start = len(rows)
        for _ in range(int(rng.integers(1, 3))):
            a = rng.normal(size=2)
            a /= np.linalg.norm(a)
            c = rng.uniform(-2.0, 2.0)
            rows.append(a)
            lo.append(c if rng.random() < 0.5 else -np.inf)
            hi.append(np.inf if np.isfinite(lo[-1]) else c)
        blocks.append(RowBlock(f"h{k}", start, len(rows)))
    C, l, u = np.array(rows), np.array(lo), np.array(hi)
    if rng.random() < 0.4:
        a = rng.normal(size=(1, 2))
        A, b, eq = a / np.linalg.norm(a), rng.uniform(-2.0, 2.0, 1), [RowBlock("line", 0, 1)]
    else:
        A, b, eq = np.zeros((0, 2)), np.zeros(0), []
    c = rng.uniform(0.5, 2.0)
    lb, ub = np.array([-c, -np.inf]), np.array([c, np.inf])
    return QPProblem(
        np.eye(2), np.zeros(2), A, b, C, l, u, lb, ub, eq, blocks, [RowBlock("box", 0, 1)]
    )


def _subset_rows(p, names):  # type: ignore[no-untyped-def]
    """Rows lo <= G x <= hi of the named blocks, plus the frame |x| <= BIG."""
    G, lo, hi = [np.eye(2)], [np.full(2, -BIG)], [np.full(2, BIG)]
    for blk in p.eq_blocks:
        if blk.name in names:
            G.append(p.A[blk.start : blk.stop])
            lo.append(p.b[blk.start : blk.stop])
            hi.append(p.b[blk.start : blk.stop])
    for blk in p.in_blocks:
        if blk.name in names:
            G.append(p.C[blk.start : blk.stop])
            lo.append(p.l[blk.start : blk.stop])
            hi.append(p.u[blk.start : blk.stop])
    if "box" in names:
        G.append(np.eye(2)[:1])
        lo.append(p.lb[:1])
        hi.append(p.ub[:1])
    return np.vstack(G), np.concatenate(lo), np.concatenate(hi)


def _least_vertex_violation(p, names) -> float:  # type: ignore[no-untyped-def]
    """Smallest, over the boundary lines' pairwise intersections, of the largest violation."""
    G, lo, hi = _subset_rows(p, names)
    lines = [(G[i], v) for i in range(len(G)) for v in (lo[i], hi[i]) if np.isfinite(v)]
    best = np.inf
    for (a1, c1), (a2, c2) in itertools.combinations(lines, 2):
        M = np.array([a1, a2])
        if abs(np.linalg.det(M)) < 1e-9:
            continue
        x = np.linalg.solve(M, [c1, c2])
        Gx = G @ x
        best = min(best, float(np.max(np.maximum(lo - Gx, Gx - hi))))
    return max(best, 0.0)


def _names(p):  # type: ignore[no-untyped-def]
    return [b.name for b in p.eq_blocks] + [b.name for b in p.in_blocks] + ["box"]


def _enumerate(p):  # type: ignore[no-untyped-def]
    """Feasibility of every subset of blocks, or None when one is too close to call."""
    names = _names(p)
    feasible = {}
    for r in range(len(names) + 1):
        for subset in itertools.combinations(names, r):
            v = _least_vertex_violation(p, set(subset))
            if 1e-7 < v < 1e-3:
                return None
            feasible[frozenset(subset)] = v <= 1e-7
    return feasible


def _conflicting_scenes() -> list[int]:
    seeds = []
    for seed in range(400):
        p = _scene(seed)
        if _least_vertex_violation(p, set(_names(p))) > 1e-3:
            seeds.append(seed)
        if len(seeds) == 12:
            break
    return seeds


@pytest.mark.parametrize("seed", _conflicting_scenes())
def test_conflict_is_an_irreducible_infeasible_subset(seed: int) -> None:
    p = _scene(seed)
    feasible = _enumerate(p)
    if feasible is None:
        pytest.skip("a subset is too close to feasible for the vertex reference")
    iis = {s for s, ok in feasible.items() if not ok and all(feasible[s - {b}] for b in s)}
    result = QPSolver().solve(p)
    assert result.status is QPStatus.RELAXED
    conflict = result.conflict
    assert frozenset(conflict) in iis, (conflict, iis)
    assert conflict == [n for n in _names(p) if n in conflict]  # the problem's order
    assert conflicting_blocks(p, prefer=result.culprits) == conflict
    if not feasible[frozenset(result.culprits)]:
        assert set(conflict) <= set(result.culprits)  # the culprits are tried last
    assert frozenset(conflicting_blocks(p)) in iis  # no preference: also a minimal conflict


def test_culprits_name_more_than_the_conflict_in_some_scene() -> None:
    # the penalty drags blocks outside the minimal conflict along: the point of `conflict`
    wider = 0
    for seed in _conflicting_scenes():
        result = QPSolver().solve(_scene(seed))
        wider += len(result.culprits) > len(result.conflict)
    assert wider > 0


def test_feasible_problem_has_no_conflict() -> None:
    p = _scene(0)
    p.l = np.where(np.isfinite(p.l), -50.0, p.l)
    p.u = np.where(np.isfinite(p.u), 50.0, p.u)
    p.A, p.b, p.eq_blocks = np.zeros((0, 2)), np.zeros(0), []
    assert _least_vertex_violation(p, set(_names(p))) == 0.0
    result = QPSolver().solve(p)
    assert result.success and result.conflict == []
    assert conflicting_blocks(p) == []


def test_weighted_inverse_dynamics_conflict_on_the_humanoid() -> None:
    # culprits: all six blocks; the conflict is a subset whose every one-dropped subset is
    # feasible (checked on build(s)'s arrays with HiGHS's interior-point method)
    from scipy.optimize import linprog

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("simple_humanoid", geometry=False)
    ctrl, s, _ = flat_footed_humanoid(robot, InverseDynamicsOptions(hierarchical=False))
    res = ctrl.solve(s)
    assert res.qp is not None and len(res.culprits) == 6
    conflict = res.qp.conflict
    assert 0 < len(conflict) < 6 and set(conflict) <= set(res.culprits)
    p = ctrl.build(s)

    def feasible(names: set[str]) -> bool:
        A_eq = [p.A[b.start : b.stop] for b in p.eq_blocks if b.name in names]
        b_eq = [p.b[b.start : b.stop] for b in p.eq_blocks if b.name in names]
        G, h = [], []
        for blk in p.in_blocks:
            if blk.name in names:
                C, lo, hi = (arr[blk.start : blk.stop] for arr in (p.C, p.l, p.u))
                G += [C[np.isfinite(hi)], -C[np.isfinite(lo)]]
                h += [hi[np.isfinite(hi)], -lo[np.isfinite(lo)]]
        bounds = [(None, None)] * p.n
        for blk in p.box_blocks:
            if blk.name in names:
                for i in range(blk.start, blk.stop):
                    lo_i = p.lb[i] if np.isfinite(p.lb[i]) else None
                    hi_i = p.ub[i] if np.isfinite(p.ub[i]) else None
                    bounds[i] = (lo_i, hi_i)
        out = linprog(
            np.zeros(p.n),
            A_ub=np.vstack(G) if G else None,
            b_ub=np.concatenate(h) if h else None,
            A_eq=np.vstack(A_eq) if A_eq else None,
            b_eq=np.concatenate(b_eq) if b_eq else None,
            bounds=bounds,
            method="highs-ipm",
        )
        assert out.status in (0, 2), out.message
        return bool(out.status == 0)

    assert not feasible(set(conflict))
    for name in conflict:
        assert feasible(set(conflict) - {name}), name
