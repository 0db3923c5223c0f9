"""BIT*: Batch Informed Trees (Gammell, Srinivasa and Barfoot, ICRA 2015).

BIT* searches an implicit random geometric graph in order of the estimated cost of the
solution through each edge, like A* on a graph that grows in batches::

    V = {q_start}, X = {goals}
    repeat:
        if both queues are empty (a new batch):
            prune: drop samples and vertices with f_hat >= c_best (they cannot improve it)
            X <- X + m new samples of {q : f_hat(q) < c_best} (informed set)
            Q_V <- V, k <- ceil(gamma_factor e (1 + 1/d) log |V + X|)
        while min_{Q_V} g(v) + h_hat(v) <= min_{Q_E} g(v) + c_hat(v, x) + h_hat(x):
            expand v: queue the edges to its k nearest samples (and, for a vertex new in
                this batch, to its k nearest vertices it could rewire) whose estimate beats
                c_best
        pop the best edge (v, x):
            if g(v) + c_hat(v, x) + h_hat(x) >= c_best: end the batch (clear the queues)
            elif g_hat(v) + c(v, x) + h_hat(x) < c_best and g(v) + c(v, x) < g(x) and the
                    edge is collision-free: add x (or rewire it) with parent v

``g`` is the cost-to-come in the tree, ``g_hat`` and ``h_hat`` admissible estimates of the
cost from the start and to the goal (the objective's lower bounds, e.g. the Euclidean distance
for the path length), ``c`` the true edge cost (collision checked last, so only edges that can
improve the solution are checked). Informed samples: the prolate hyperspheroid of informed
RRT* for the Euclidean length with one goal, otherwise rejection sampling of
``g_hat(q) + h_hat(q) < c_best``. Anytime: it stops at the time or iteration (sample) limit
and returns the best path with its cost over time.

Thread safety: :class:`BITStarOptions` is immutable; :func:`bit_star` keeps its state local to the
call apart from the configuration space it is given (one space per thread, see
:class:`~taskspace.planning.ConfigurationSpace`).
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import check_count, check_positive, check_seed
from taskspace.planning.certify import FailedRegions, plan_certified
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray
from taskspace.planning.goals import goal_states, region_sample
from taskspace.planning.limits import (
    Budget,
    edge_case,
    edge_case_result,
    planner_limits,
    result_length,
)
from taskspace.planning.objectives import (
    OptimizationObjective,
    optimum_lower_bound,
    reached_optimum,
    space_objective,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus, Tree
from taskspace.planning.rrt_star import _rotation_to_world, informed_sample


@dataclass(frozen=True, kw_only=True)
class BITStarOptions:
    """Settings of :func:`bit_star`.

    Attributes:
        batch_size: samples ``m`` added per batch (OMPL's default is 100).
        gamma_factor: ``k = ceil(gamma_factor e (1 + 1/d) log q)`` nearest neighbours
            (``q``: vertices and samples; >= 1 for the guarantee).
        max_iterations: samples drawn in total (an integer >= 0, or ``None`` with a finite
            time limit; see :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = none; NaN refused).
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
        stop_at_first: return as soon as a first solution exists (not anytime).
        prune: drop samples and vertices that cannot improve the solution at each batch.
        certify: prove the returned path free between its checked points
            (:func:`~taskspace.planning.certify_path`, conservative advancement on the robot's
            geometry); an uncertified path is re-planned with the next seeds
            (``certify_retries`` times, within the time limit), and if none can be certified
            the result has ``success=False``, status ``UNCERTIFIED`` and the failing segment
            in ``log``. Needs a space built on a robot.
        certify_retries: re-plans (next seeds) after an uncertified path; a re-plan accepts a
            motion near a spot where an earlier certificate failed only if it is certified
            there (:class:`~taskspace.planning.certify.FailedRegions`).
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
    """

    batch_size: int = 100
    gamma_factor: float = 1.0
    max_iterations: int | None = 5_000
    time_limit_s: float | None = 1.0
    seed: int = 0
    stop_at_first: bool = False
    prune: bool = True
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4


class _States:
    """Every state met (tree vertices and samples) with its tree data; indices never move."""

    def __init__(self, dim: int) -> None:
        self.q = np.empty((512, dim))
        self.g = np.full(512, math.inf)
        self.g_hat = np.zeros(512)
        self.h_hat = np.zeros(512)
        self.parent = np.full(512, -1, dtype=np.int64)
        self.in_tree = np.zeros(512, dtype=bool)
        self.is_sample = np.zeros(512, dtype=bool)
        self.old = np.zeros(512, dtype=bool)
        self.children: list[set[int]] = []
        self.n = 0

    def add(self, q: FloatArray, g_hat: FloatArray, h_hat: FloatArray) -> npt.NDArray[np.int64]:
        m = q.shape[0]
        if self.n + m > self.q.shape[0]:
            size = max(2 * self.q.shape[0], self.n + m)
            self.q = np.resize(self.q, (size, self.q.shape[1]))
            for name, fill in (("g", math.inf), ("g_hat", 0.0), ("h_hat", 0.0), ("parent", -1)):
                old = getattr(self, name)
                grown = np.full(size, fill, dtype=old.dtype)
                grown[: self.n] = old[: self.n]
                setattr(self, name, grown)
            for name in ("in_tree", "is_sample", "old"):
                grown_b = np.zeros(size, dtype=bool)
                grown_b[: self.n] = getattr(self, name)[: self.n]
                setattr(self, name, grown_b)
        ids = np.arange(self.n, self.n + m, dtype=np.int64)
        self.q[ids] = q
        self.g[ids] = math.inf
        self.g_hat[ids] = g_hat
        self.h_hat[ids] = h_hat
        self.parent[ids] = -1
        self.in_tree[ids] = False
        self.is_sample[ids] = True
        self.old[ids] = False
        self.children.extend(set() for _ in range(m))
        self.n += m
        return ids

    def propagate(self, root: int, delta: float) -> None:
        """Add ``delta`` to the cost-to-come of ``root`` and its whole subtree."""
        stack = [root]
        while stack:
            i = stack.pop()
            self.g[i] += delta
            stack.extend(self.children[i])


def bit_star(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: BITStarOptions | None = None,
    *,
    objective: OptimizationObjective | None = None,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Plan with BIT* (see the module docstring); anytime within the limits.

    Args:
        space: configuration space with validity checker and local planner.
        start: ``q_start`` (size d).
        goal: one goal configuration (d,), several (k, d) (the path ends at the cheapest),
            or a :class:`~taskspace.planning.GoalRegion` (one goal sample per batch; the
            heuristic to the goal is then 0).
        options: settings (batch size, ``gamma_factor``, limits).
        objective: path cost (default: Euclidean :class:`~taskspace.planning.PathLength`;
            on a joint-manifold space the length in its metric, and any objective is taken
            along its geodesics, see :mod:`~taskspace.planning.objectives`); its lower
            bounds are BIT*'s heuristics.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        The best path found; ``cost`` is its objective cost; ``log`` holds ``costs`` and
        ``cost_times`` (each improvement [s]), ``first_solution_s``, ``batches``,
        ``tree_size``, ``stopped_by``; ``trees[0]`` is the search tree.

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: bad options (see :mod:`taskspace.planning.limits`); ``certify``
            on a space without a robot.
    """
    opts = options or BITStarOptions()
    if not opts.certify:
        return _plan(space, start, goal, opts, objective, rng)
    return plan_certified(space, opts, lambda o, r: _plan(space, start, goal, o, objective, rng, r))


def _plan(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: BITStarOptions,
    objective: OptimizationObjective | None,
    rng: np.random.Generator | None,
    regions: FailedRegions | None = None,
) -> PlannerResult:
    """:func:`bit_star` without certification.

    ``regions``: the failed regions of earlier certificates (a certified re-plan): every edge
    must be certified inside them (:class:`~taskspace.planning.certify.FailedRegions`).
    """
    cap, limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    batch = check_count(opts.batch_size, "batch_size", minimum=1)
    check_positive(opts.gamma_factor, "gamma_factor")
    cost_of = space_objective(space, objective)
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    t0 = time.perf_counter()
    budget = Budget(cap, limit, t0)
    checks0, edges0 = space.checks, space.edge_checks
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    found = edge_case(space, q_start, goals, region, budget)
    if found is not None and regions is not None:
        found = regions.edge_case(found)
    if found is not None:
        return edge_case_result(
            space, found, budget, (checks0, edges0), cost_of, goal_count=len(goals)
        )
    d = space.dim
    k_factor = opts.gamma_factor * math.e * (1 + 1 / space.tangent_dim)
    goal_q = list(goals)
    optimum_bound = optimum_lower_bound(cost_of, q_start, goals, region)

    def heuristics(q: FloatArray) -> tuple[FloatArray, FloatArray]:
        g_hat = cost_of.cost_lower_bounds(q_start, q)
        if region is not None or not goal_q:
            return g_hat, np.zeros(q.shape[0])
        h = np.min([cost_of.cost_lower_bounds(q, gq) for gq in goal_q], axis=0)
        return g_hat, np.asarray(h, dtype=np.float64)

    S = _States(d)
    root = int(S.add(q_start[None, :], *heuristics(q_start[None, :]))[0])
    S.is_sample[root], S.in_tree[root], S.g[root] = False, True, 0.0
    goal_ids: list[int] = []
    if goals:
        arr = np.asarray(goals).reshape(-1, d)
        goal_ids = S.add(arr, *heuristics(arr)).tolist()
    if region is not None and region.contains(q_start):
        goal_ids.append(root)
    rotation = None
    if cost_of.is_euclidean_length and region is None and len(goals) == 1:
        if np.linalg.norm(goals[0] - q_start) > 0:
            rotation = _rotation_to_world(q_start, goals[0])

    def best_goal() -> tuple[int, float]:
        if not goal_ids:
            return -1, math.inf
        ids = np.asarray(goal_ids)
        i = int(ids[np.argmin(S.g[ids])])
        return i, float(S.g[i])

    queue_v: list[tuple[float, int]] = []
    in_qv: set[int] = set()
    queue_e: list[tuple[float, float, float, int, int]] = []  # key, g(v) + c_hat, c_hat, v, x
    exact = cost_of.bound_is_exact
    failed: set[tuple[int, int]] = set()
    cost_times: list[float] = []
    costs: list[float] = []
    samples = batches = expansions = 0
    c_best = math.inf
    k = 1

    def prune(c: float) -> None:
        n = S.n
        f_hat = S.g_hat[:n] + S.h_hat[:n]
        S.is_sample[:n] &= f_hat < c
        # Strictly worse than c (with a rounding margin: vertices on the best path have
        # f_hat = c up to rounding), and never a vertex of the best path itself.
        drop = S.in_tree[:n] & (f_hat > c * (1 + 1e-9) + 1e-12)
        drop[root] = False
        drop[goal_ids] = False
        best, _ = best_goal()
        while best >= 0:
            drop[best] = False
            best = int(S.parent[best])
        if not drop.any():
            return
        # Cut the dropped vertices; their descendants that could still help become samples.
        S.in_tree[:n] &= ~drop
        for i in np.flatnonzero(drop).tolist():
            p = int(S.parent[i])
            if p >= 0:
                S.children[p].discard(i)
            S.parent[i] = -1
            S.g[i] = math.inf
        reach = np.zeros(n, dtype=bool)
        stack = [root]
        while stack:
            i = stack.pop()
            reach[i] = True
            stack.extend(S.children[i])
        lost = S.in_tree[:n] & ~reach
        for i in np.flatnonzero(lost).tolist():
            S.children[i] = {c_ for c_ in S.children[i] if reach[c_]}
            S.in_tree[i] = False
            S.parent[i] = -1
            S.g[i] = math.inf
            S.is_sample[i] = bool(f_hat[i] < c)
        for i in np.flatnonzero(drop).tolist():
            S.children[i] = set()

    def draw(m: int) -> FloatArray:
        """``m`` free samples of the informed set (fewer if the set is hard to hit)."""
        out: list[FloatArray] = []
        have = 0
        for _ in range(100):
            if have >= m or budget.out_of_time():
                break
            if rotation is not None and math.isfinite(c_best):
                cand = np.array(
                    [informed_sample(rng, q_start, goals[0], c_best, rotation) for _ in range(m)]
                )
                cand = cand[np.all((cand >= space.lower) & (cand <= space.upper), axis=1)]
            else:
                cand = space.sample_uniform(rng, m)
                if math.isfinite(c_best):
                    g_hat, h_hat = heuristics(cand)
                    cand = cand[g_hat + h_hat < c_best]
            if cand.shape[0]:
                cand = cand[space.checker.are_valid(cand)]
            out.append(cand)
            have += cand.shape[0]
        return np.vstack(out)[:m] if out else np.empty((0, d))

    def nearest(v: int, mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
        """The ``k`` states of ``mask`` nearest to state ``v`` (``v`` excluded)."""
        ids = np.flatnonzero(mask)
        ids = ids[ids != v]
        if ids.size <= k:
            return ids
        return ids[np.argpartition(space.distances(S.q[ids], S.q[v]), k - 1)[:k]]

    def expand(v: int) -> None:
        """Queue the edges from ``v`` to its k nearest samples (and vertices, if new)."""
        in_qv.discard(v)
        n = S.n
        gv, ghv = float(S.g[v]), float(S.g_hat[v])
        near = nearest(v, S.is_sample[:n])
        if near.size:
            c_hat = cost_of.cost_lower_bounds(S.q[v], S.q[near])
            for x, ch in zip(near.tolist(), c_hat.tolist()):
                if ghv + ch + S.h_hat[x] < c_best:
                    heapq.heappush(queue_e, (gv + ch + S.h_hat[x], gv + ch, ch, v, x))
        if S.old[v]:
            return
        near = nearest(v, S.in_tree[:n])
        if near.size:
            c_hat = cost_of.cost_lower_bounds(S.q[v], S.q[near])
            for x, ch in zip(near.tolist(), c_hat.tolist()):
                if (
                    ghv + ch + S.h_hat[x] < c_best
                    and gv + ch < S.g[x]
                    and S.parent[v] != x
                    and S.parent[x] != v
                ):
                    heapq.heappush(queue_e, (gv + ch + S.h_hat[x], gv + ch, ch, v, x))

    while True:
        if not queue_e and not queue_v:
            # A new batch.
            if samples >= cap or budget.out_of_time():
                budget.exhausted(samples)
                break
            if opts.prune and math.isfinite(c_best):
                prune(c_best)
            m = min(batch, cap - samples)
            fresh = draw(m)
            samples += m
            batches += 1
            if fresh.shape[0]:
                S.add(fresh, *heuristics(fresh))
            if region is not None:
                new = np.arange(S.n - fresh.shape[0], S.n)
                goal_ids += [int(i) for i in new if region.contains(S.q[i])]
                q = None if budget.out_of_time() else region_sample(space, region, rng)
                if q is not None:
                    if space.within_bounds(q) and space.is_valid(q):
                        i = int(S.add(q[None, :], *heuristics(q[None, :]))[0])
                        if region.contains(q):  # else an ordinary sample
                            goal_ids.append(i)
            n = S.n
            S.old[:n] = S.in_tree[:n]
            tree_ids = np.flatnonzero(S.in_tree[:n])
            queue_v = [(float(S.g[i] + S.h_hat[i]), int(i)) for i in tree_ids]
            heapq.heapify(queue_v)
            in_qv = set(tree_ids.tolist())
            active = int(np.count_nonzero(S.in_tree[:n] | S.is_sample[:n]))
            k = max(1, math.ceil(k_factor * math.log(max(active, 2))))
            continue
        if budget.out_of_time():
            break
        # Expand vertices while the best vertex could give a better edge than the best edge.
        while queue_v:
            key_v, v = queue_v[0]
            if v not in in_qv or not S.in_tree[v]:
                heapq.heappop(queue_v)
                continue
            if queue_e and key_v > queue_e[0][0]:
                break
            if budget.out_of_time():  # expansions scan every state: many at high dof
                break
            heapq.heappop(queue_v)
            expand(v)
            expansions += 1
        if budget.stopped_by:
            break
        if not queue_e:
            queue_v = []
            continue
        _, _, c_hat, v, x = heapq.heappop(queue_e)
        if not S.in_tree[v]:
            continue
        if S.g[v] + c_hat + S.h_hat[x] >= c_best:
            queue_e, queue_v = [], []  # nothing left in this batch can improve the solution
            in_qv = set()
            continue
        if S.g[v] + c_hat >= S.g[x] or (v, x) in failed:
            continue
        c = c_hat if exact else cost_of.motion_cost(S.q[v], S.q[x])
        if S.g_hat[v] + c + S.h_hat[x] >= c_best or S.g[v] + c >= S.g[x]:
            continue
        if budget.out_of_time():  # read before each edge check: the overrun is one edge
            break
        if not space.motion_valid(S.q[v], S.q[x]) or (
            regions is not None and not regions.allows(S.q[v], S.q[x])
        ):
            failed.add((v, x))
            failed.add((x, v))
            continue
        new_g = float(S.g[v] + c)
        if S.in_tree[x]:
            S.children[int(S.parent[x])].discard(x)
            S.parent[x] = v
            S.children[v].add(x)
            S.propagate(x, new_g - float(S.g[x]))
        else:
            S.is_sample[x] = False
            S.in_tree[x] = True
            S.parent[x] = v
            S.children[v].add(x)
            S.g[x] = new_g
            heapq.heappush(queue_v, (new_g + float(S.h_hat[x]), x))
            in_qv.add(x)
        _, c_now = best_goal()
        if c_now < c_best - 1e-12:
            c_best = c_now
            cost_times.append(budget.elapsed())
            costs.append(c_best)
            if opts.stop_at_first:
                budget.stopped_by = "first solution"
                break
            if reached_optimum(c_best, optimum_bound):
                budget.stopped_by = "optimal"  # the cost equals a lower bound of the optimum
                break
    goal_node, c_final = best_goal()
    success = goal_node >= 0 and math.isfinite(c_final)
    n = S.n
    ids: list[int] = []
    if success:
        ids = [goal_node]
        while S.parent[ids[-1]] >= 0:
            ids.append(int(S.parent[ids[-1]]))
        ids.reverse()
    path = S.q[ids].copy() if success else np.empty((0, d))
    tree_ids = np.flatnonzero(S.in_tree[:n])
    remap = np.full(n, -1, dtype=np.int64)
    remap[tree_ids] = np.arange(tree_ids.size)
    parents = np.where(S.parent[tree_ids] >= 0, remap[np.maximum(S.parent[tree_ids], 0)], -1)
    limit_status = (
        PlannerStatus.TIME_LIMIT if budget.stopped_by == "time" else PlannerStatus.ITERATION_LIMIT
    )
    return PlannerResult(
        success=success,
        status=PlannerStatus.SOLVED if success else limit_status,
        path=path,
        path_length=result_length(space, path, success),
        iterations=samples,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=budget.elapsed(),
        trees=[Tree(S.q[tree_ids].copy(), parents.astype(np.int64))],
        cost=c_final if success else math.inf,
        log={
            "first_solution_s": cost_times[0] if cost_times else math.inf,
            "cost_times": cost_times,
            "costs": costs,
            "batches": float(batches),
            "expansions": float(expansions),
            "tree_size": float(tree_ids.size),
            "goal_states": float(len(set(goal_ids))),
            "stopped_by": budget.stopped_by,
        },
    )
