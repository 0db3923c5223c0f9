"""PRM* and Lazy PRM*: asymptotically optimal, anytime roadmaps.

PRM* (Karaman and Frazzoli 2011) is the PRM of :mod:`taskspace.planning.prm` with a number of
neighbours that grows with the roadmap: each new node is joined to its

    k_n = ceil(gamma_factor e (1 + 1/d) log n)

nearest nodes (``n`` nodes, dimension ``d``; ``gamma_factor >= 1`` gives the guarantee), and
the shortest roadmap path converges to the optimum almost surely. Here the roadmap grows in
batches of ``batch_size`` free samples, start and goal being roadmap nodes from the start (as
OMPL's ``PRMstar`` adds them as milestones); after each batch the shortest path from start to
a goal (scipy's Dijkstra, edge weights = the objective's motion costs) gives the best cost so
far, recorded over time. The planners are anytime: they grow the roadmap until the time or
iteration limit and return the best path.

Lazy PRM* (OMPL's ``LazyPRMstar``; Bohlin and Kavraki 2000) adds the edges unchecked; after a
batch it repeats "shortest path, check its unchecked edges (coarse to fine, one checker call
per pass, see :func:`~taskspace.planning.lazy_prm.lazy_prm_query`), remove the colliding ones"
until the shortest path is free or none is left. Only edges on candidate shortest paths are
ever checked; every edge of a returned path is free at the space's resolution.

Roadmaps record the obstacle world's version (:attr:`ConfigurationSpace.world_version`) and
the robot limits' version (:attr:`ConfigurationSpace.model_version`); a query on a roadmap
built for another version is refused (see :mod:`~taskspace.planning.prm`).

Thread safety: :class:`PRMStarOptions` is immutable; the planners keep their state local to the
call apart from the configuration space they are given (one space per thread).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from taskspace._validation import check_count, check_positive, check_seed
from taskspace.errors import InvalidInputError
from taskspace.planning.certify import certify_keeping
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray
from taskspace.planning.goals import goal_states, region_sample
from taskspace.planning.lazy_prm import LazyRoadmap, _check_edges
from taskspace.planning.limits import Budget, edge_case, planner_limits, result_length
from taskspace.planning.objectives import (
    OptimizationObjective,
    optimum_lower_bound,
    reached_optimum,
    space_objective,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.prm import Roadmap, Segment, avoided_pairs, uncertified_segment
from taskspace.planning.sampling import sample_free


@dataclass(frozen=True, kw_only=True)
class PRMStarOptions:
    """Settings of :func:`prm_star` and :func:`lazy_prm_star`.

    Attributes:
        batch_size: free samples added to the roadmap per growth step.
        gamma_factor: ``k_n = ceil(gamma_factor e (1 + 1/d) log n)`` (>= 1 for the guarantee).
        max_iterations: roadmap samples (an integer >= 0, or ``None`` with a finite time
            limit; see :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = none; NaN refused).
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
        stop_at_first: return after the first batch that connects start and goal.
        coarse_resolution: first-pass resolution of the edge checks [rad or m] (PRM*
            checks a batch's edges coarse then fine, Lazy PRM* a candidate path's; every
            point of the space's resolution is checked before an edge is called free).
        certify: prove the returned path free between its checked points
            (:func:`~taskspace.planning.certify_path`, conservative advancement on the robot's
            geometry); an uncertified path is re-planned (a new roadmap) with the next seeds
            (``certify_retries`` times, within the time limit) without the segments whose
            certificate failed (the straight line would otherwise be passed and taken
            again), and if none can be certified
            the result has ``success=False``, status ``UNCERTIFIED`` and the failing segment
            in ``log``. Needs a space built on a robot.
        certify_retries: re-plans (next seeds) after an uncertified path.
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
        expand_fraction: the fraction of each batch's samples spent on the *expansion
            step* of Kavraki, Svestka, Latombe and Overmars (1996), as OMPL's PRM and PRMstar
            do (a third of their time; OMPL's LazyPRMstar has none): random-bounce walks of up to
            5 steps from roadmap nodes drawn with probability proportional to their failed
            connection ratio (typically the start and the goal in a tight spot, which
            uniform samples rarely reach), each step moving towards a uniform sample until
            the first colliding point at the space's resolution; the walk's nodes are chained
            to the node by those checked segments and its end is connected to its ``k_n``
            nearest nodes as any new node. Only until a first path is found: then every
            sample is uniform again, as PRM*'s convergence analysis assumes (the extra nodes
            only add edges). Lazy PRM* draws the nodes from the failure ratio of the edges
            it has checked (those of candidate shortest paths; unchecked edges do not count)
            and checks the walks' lines as PRM* does, so the walks' chain edges are known
            free. No walk is made while no node has a failed connection. 0 disables it.
    """

    batch_size: int = 64
    gamma_factor: float = 1.0
    max_iterations: int | None = 2_000
    time_limit_s: float | None = 1.0
    seed: int = 0
    stop_at_first: bool = False
    coarse_resolution: float = 0.15
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4
    expand_fraction: float = 0.5


BOUNCE_STEPS = 5
"""Steps of a random-bounce walk of the expansion (OMPL's ``MAX_RANDOM_BOUNCE_STEPS``)."""


class _Graph:
    """Nodes (grown by doubling) and the undirected edges ``(i, j, cost, status)``."""

    def __init__(self, dim: int) -> None:
        self.nodes = np.empty((256, dim))
        self.n = 0
        self.i: list[npt.NDArray[np.int64]] = []
        self.j: list[npt.NDArray[np.int64]] = []
        self.cost: list[FloatArray] = []
        self.status: list[npt.NDArray[np.int8]] = []

    def add_nodes(self, q: FloatArray) -> npt.NDArray[np.int64]:
        m = q.shape[0]
        if self.n + m > self.nodes.shape[0]:
            grown = np.empty((max(2 * self.nodes.shape[0], self.n + m), self.nodes.shape[1]))
            grown[: self.n] = self.nodes[: self.n]
            self.nodes = grown
        self.nodes[self.n : self.n + m] = q
        ids = np.arange(self.n, self.n + m, dtype=np.int64)
        self.n += m
        return ids

    def add_edges(
        self, pairs: npt.NDArray[np.int64], cost: FloatArray, status: npt.NDArray[np.int8]
    ) -> None:
        self.i.append(pairs[:, 0])
        self.j.append(pairs[:, 1])
        self.cost.append(cost)
        self.status.append(status)

    def edges(self) -> tuple[npt.NDArray[np.int64], FloatArray, npt.NDArray[np.int8]]:
        """All edges: pairs (m, 2), costs (m,), status (m,); concatenated once per call."""
        if not self.i:
            return np.empty((0, 2), np.int64), np.empty(0), np.empty(0, np.int8)
        if len(self.i) > 1:
            self.i = [np.concatenate(self.i)]
            self.j = [np.concatenate(self.j)]
            self.cost = [np.concatenate(self.cost)]
            self.status = [np.concatenate(self.status)]
        return np.stack([self.i[0], self.j[0]], axis=1), self.cost[0], self.status[0]


def _shortest(
    n: int, pairs: npt.NDArray[np.int64], cost: FloatArray, goals: list[int]
) -> tuple[list[int], float]:
    """Shortest path from node 0 to the cheapest goal over ``pairs``: node ids and cost."""
    if pairs.shape[0] == 0 or not goals:
        return [], math.inf
    weights = np.maximum(cost, 1e-12)  # zero weights would vanish from the sparse matrix
    graph = csr_matrix((weights, (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    dist, pred = dijkstra(graph, directed=False, indices=0, return_predecessors=True)
    goal_arr = np.asarray(goals)
    best = int(goal_arr[np.argmin(dist[goal_arr])])
    if not np.isfinite(dist[best]):
        return [], math.inf
    ids = [best]
    while ids[-1] != 0:
        ids.append(int(pred[ids[-1]]))
    ids.reverse()
    return ids, float(dist[best])


class _EdgeIndex:
    """Index in ``pairs`` (rows ``i < j``) of node pairs, by binary search on sorted keys."""

    def __init__(self, pairs: npt.NDArray[np.int64], n: int) -> None:
        self.n = n
        keys = pairs[:, 0] * n + pairs[:, 1]
        self.order = np.argsort(keys)
        self.sorted = keys[self.order]

    def __call__(self, ids: list[int]) -> npt.NDArray[np.int64]:
        a = np.minimum(ids[:-1], ids[1:]).astype(np.int64)
        b = np.maximum(ids[:-1], ids[1:]).astype(np.int64)
        pos = np.searchsorted(self.sorted, a * self.n + b)
        return np.asarray(self.order[pos], dtype=np.int64)


_FIRST_POINTS = 256.0
"""Points checked in the first chunk of edges (PRM*): later chunks are sized from its time."""

_MAX_CHUNK = 256
"""Most edges checked in one chunk (PRM*)."""


def _plan(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMStarOptions | None,
    objective: OptimizationObjective | None,
    rng: np.random.Generator | None,
    lazy: bool,
    avoid: Sequence[Segment] = (),
) -> tuple[PlannerResult, _Graph, tuple[int | None, int | None]]:
    """One PRM* or Lazy PRM* run; the edges along a segment of ``avoid`` are not used."""
    opts = options or PRMStarOptions()
    cap, limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    batch = check_count(opts.batch_size, "batch_size", minimum=1)
    check_positive(opts.gamma_factor, "gamma_factor")
    coarse = check_positive(opts.coarse_resolution, "coarse_resolution")
    cost_of = space_objective(space, objective)
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    t0 = time.perf_counter()
    budget = Budget(cap, limit, t0)
    checks0, edges0 = space.checks, space.edge_checks
    version = space.world_version
    model_version = space.model_version
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    optimum_bound = optimum_lower_bound(cost_of, q_start, goals, region)
    d = space.dim
    k_prm = opts.gamma_factor * math.e * (1 + 1 / space.tangent_dim)
    stride = max(1, math.floor(coarse / space.edge_resolution + 1e-9))

    expand = float(opts.expand_fraction)
    if not 0.0 <= expand <= 1.0:
        raise InvalidInputError(f"expand_fraction must be in [0, 1], got {opts.expand_fraction}")
    expansion_nodes = 0
    attempts = np.zeros(256)  # edges tried and found free per node (the expansion's weights)
    successes = np.zeros(256)

    graph = _Graph(d)
    graph.add_nodes(q_start[None, :])
    goal_ids = graph.add_nodes(np.asarray(goals).reshape(-1, d)).tolist() if goals else []
    if region is not None and region.contains(q_start):
        goal_ids.append(0)
    new = np.arange(graph.n, dtype=np.int64)
    samples = rounds = 0
    best_ids: list[int] = []
    best_cost = math.inf
    cost_times: list[float] = []
    costs: list[float] = []
    # the limits' edge cases (PRM*'s first round, with no sample, is the straight lines)
    found = edge_case(space, q_start, goals, region, budget, lines=False)
    if found is not None and found[1] is PlannerStatus.SOLVED:
        same = [i for i, g in enumerate(goals) if np.array_equal(g, q_start)]
        best_ids = [0] if found[0].shape[0] == 1 else [0, int(goal_ids[same[0]])]
        best_cost = float(cost_of.path_cost(found[0]))
        cost_times.append(budget.elapsed())
        costs.append(best_cost)
        budget.stopped_by = "first solution"
    while found is None:
        # Connect the new nodes to their k_n nearest nodes.
        n = graph.n
        nodes = graph.nodes[:n]
        k = min(n - 1, math.ceil(k_prm * math.log(n))) if n > 1 else 0
        if k > 0 and new.size:
            if space.is_euclidean:
                _, idx = cKDTree(nodes).query(nodes[new], k=k + 1)
                idx = np.asarray(idx).reshape(new.size, k + 1)
            else:  # the manifold's metric, node by node
                idx = np.stack(
                    [np.argpartition(space.distances(nodes, nodes[i]), k)[: k + 1] for i in new]
                )
            pairs = np.stack([np.repeat(new, k + 1), idx.ravel()], axis=1)
            pairs = pairs[pairs[:, 0] != pairs[:, 1]]
            pairs = np.unique(np.sort(pairs, axis=1), axis=0)
            cost = cost_of.motion_costs(nodes[pairs[:, 0]], nodes[pairs[:, 1]])
            if lazy:
                graph.add_edges(pairs, cost, np.zeros(len(cost), np.int8))
            else:
                # Coarse then fine passes over chunks of edges, one checker call per pass;
                # a chunk holds about limit / 50 seconds of checks (its points times the
                # time per point so far), so that the limit is kept with costly checkers.
                free = np.zeros(len(cost), dtype=bool)
                a_rows, b_rows = nodes[pairs[:, 0]], nodes[pairs[:, 1]]
                if space.manifold is None:
                    lengths = np.linalg.norm(b_rows - a_rows, axis=1)
                else:
                    lengths = space.manifold.distances(a_rows, b_rows)
                points = np.cumsum(np.ceil(lengths / space.edge_resolution) + 1.0)
                lo, per_point = 0, math.inf
                while lo < len(cost):
                    if budget.out_of_time():
                        break
                    size = _MAX_CHUNK
                    if math.isfinite(limit):
                        allowed = _FIRST_POINTS
                        if math.isfinite(per_point):
                            allowed = max(1.0, limit / 50.0 / per_point)
                        done = points[lo - 1] if lo else 0.0
                        fit = int(np.searchsorted(points, done + allowed, side="right")) - lo
                        size = min(_MAX_CHUNK, max(1, fit))
                    chunk = pairs[lo : lo + size]
                    space.edge_checks += chunk.shape[0]
                    ends = [(nodes[a], nodes[b]) for a, b in chunk.tolist()]
                    t_chunk, checks_before = time.perf_counter(), space.checks
                    free[lo : lo + chunk.shape[0]] = _check_edges(
                        space, ends, stride, complete=True
                    )
                    checked = space.checks - checks_before
                    if checked > 0:
                        per_point = (time.perf_counter() - t_chunk) / checked
                    lo += chunk.shape[0]
                graph.add_edges(pairs[free], cost[free], np.ones(int(free.sum()), np.int8))
                attempts, successes = _fit(attempts, graph.n), _fit(successes, graph.n)
                tried = pairs[:lo]
                np.add.at(attempts, tried.ravel(), 1.0)
                np.add.at(successes, tried[free[:lo]].ravel(), 1.0)
        # Search (and, lazily, validate) the shortest path.
        pairs_all, cost_all, status = graph.edges()
        edge_index: _EdgeIndex | None = None
        usable = np.ones(len(pairs_all), dtype=bool)
        for i, j in avoided_pairs(nodes, avoid) if avoid else ():
            usable &= (pairs_all[:, 0] != i) | (pairs_all[:, 1] != j)
        while True:
            rounds += 1
            keep = status >= 0
            if avoid:
                keep &= usable
            ids, total = _shortest(n, pairs_all[keep], cost_all[keep], goal_ids)
            if not ids or not lazy:
                break
            if edge_index is None:
                edge_index = _EdgeIndex(pairs_all, n)
            path_edges = edge_index(ids)
            unknown = path_edges[status[path_edges] == 0]
            if unknown.size == 0:
                break
            if budget.out_of_time():
                ids = []
                break
            space.edge_checks += int(unknown.size)
            ends = [(nodes[pairs_all[e, 0]], nodes[pairs_all[e, 1]]) for e in unknown.tolist()]
            ok = _check_edges(space, ends, stride)
            if ok.all():
                status[unknown] = 1
            else:
                status[unknown[~ok]] = -1  # the others are re-checked (cheaply) if needed
        if ids and total < best_cost - 1e-12:
            best_ids, best_cost = ids, total
            cost_times.append(budget.elapsed())
            costs.append(total)
        if best_ids and reached_optimum(best_cost, optimum_bound):
            budget.stopped_by = "optimal"  # the cost equals a lower bound of the optimum
            break
        if (opts.stop_at_first and best_ids) or budget.exhausted(samples):
            if opts.stop_at_first and best_ids:
                budget.stopped_by = "first solution"
            break
        # Grow: a batch of free samples (and a goal sample from a region), and the
        # expansion's random-bounce walks.
        m = min(batch, cap - samples)
        expanding = not (best_ids or budget.out_of_time())  # until a first path
        if expanding and lazy:
            # Lazy PRM*: the failure statistics of the edges checked so far (those of the
            # candidate paths); a node none of whose edges was checked has weight 0.
            attempts, successes = _lazy_counts(graph)
        walks = math.ceil(expand * m / BOUNCE_STEPS) if expanding else 0
        walks = min(walks, m // BOUNCE_STEPS)
        if walks and not _has_failures(attempts, successes, graph.n):
            walks = 0  # no node failed to connect yet: every sample uniform
        m_uniform = m - walks * BOUNCE_STEPS
        fresh = sample_free(space, m_uniform, rng, max_draws=1000 * max(1, m_uniform))
        samples += m
        new = graph.add_nodes(fresh)
        if walks:
            attempts, successes = _fit(attempts, graph.n), _fit(successes, graph.n)
            walk_ends, chain_edges = _bounce_walks(
                space, graph, (attempts, successes), walks, rng, budget
            )
            new = np.append(new, walk_ends)
            expansion_nodes += chain_edges.shape[0]
            attempts, successes = _fit(attempts, graph.n), _fit(successes, graph.n)
            if chain_edges.shape[0]:
                chain_cost = cost_of.motion_costs(
                    graph.nodes[chain_edges[:, 0]], graph.nodes[chain_edges[:, 1]]
                )
                graph.add_edges(
                    np.sort(chain_edges, axis=1), chain_cost, np.ones(len(chain_cost), np.int8)
                )
                # walk nodes count as hard to connect (OMPL: one attempt, no success)
                inner = np.setdiff1d(chain_edges[:, 1], walk_ends)
                attempts[inner] = 1.0
                successes[inner] = 0.0
        if region is not None:
            q = region_sample(space, region, rng)
            if q is not None and space.within_bounds(q) and space.is_valid(q):
                new = np.append(new, graph.add_nodes(q[None, :]))
            # goals: the new nodes inside the region (a sample the region does not contain
            # stays an ordinary node)
            goal_ids += [int(i) for i in new if region.contains(graph.nodes[i])]
            goal_ids = sorted(set(goal_ids))
    success = bool(best_ids)
    path = graph.nodes[best_ids].copy() if success else np.empty((0, d))
    limit_status = (
        PlannerStatus.TIME_LIMIT if budget.stopped_by == "time" else (PlannerStatus.ITERATION_LIMIT)
    )
    result = PlannerResult(
        success=success,
        status=PlannerStatus.SOLVED if success else limit_status,
        path=path,
        path_length=result_length(space, path, success),
        iterations=samples,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=budget.elapsed(),
        cost=best_cost,
        log={
            "first_solution_s": cost_times[0] if cost_times else math.inf,
            "cost_times": cost_times,
            "costs": costs,
            "roadmap_nodes": float(graph.n),
            "roadmap_edges": float(graph.edges()[0].shape[0]),
            "search_rounds": float(rounds),
            "expansion_nodes": float(expansion_nodes),
            "goal_states": float(len(goal_ids)),
            "stopped_by": budget.stopped_by,
        },
    )
    return result, graph, (version, model_version)


def _lazy_counts(graph: _Graph) -> tuple[FloatArray, FloatArray]:
    """Per node: its checked edges (free or colliding) and its free ones (Lazy PRM*)."""
    pairs, _, status = graph.edges()
    n = 2 * graph.n
    checked = pairs[status != 0].ravel()
    free = pairs[status > 0].ravel()
    attempts = np.bincount(checked, minlength=n).astype(np.float64)
    successes = np.bincount(free, minlength=n).astype(np.float64)
    return attempts, successes


def _has_failures(attempts: FloatArray, successes: FloatArray, n: int) -> bool:
    """Whether some node has a failed connection (a walk can start)."""
    return bool(np.any(attempts[:n] > successes[:n]))


def _fit(counts: FloatArray, n: int) -> FloatArray:
    """``counts`` with room for ``n`` nodes (zeros appended)."""
    if counts.size >= n:
        return counts
    out = np.zeros(2 * n)
    out[: counts.size] = counts
    return out


def _bounce_walks(
    space: ConfigurationSpace,
    graph: _Graph,
    counts: tuple[FloatArray, FloatArray],
    walks: int,
    rng: np.random.Generator,
    budget: Budget,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The expansion step: random-bounce walks from nodes that fail to connect.

    Each walk starts at a node drawn with probability proportional to its failed connection
    ratio ``(attempts - successes) / attempts`` and takes up to :data:`BOUNCE_STEPS` steps,
    each towards a uniform sample as far as the line is free: its points at the space's
    resolution are checked in order up to the first colliding one (one checker call), and
    the last free one is the next node (the segment to it is free at the resolution: its
    points are those checked). Returns the walks' end nodes (to be connected to their
    nearest nodes) and the chain edges ``(from, to)`` (free). No walk starts after the
    deadline.
    """
    attempts, successes = counts
    n = graph.n
    tried = attempts[:n]
    weights = np.where(tried > 0, (tried - successes[:n]) / np.maximum(tried, 1.0), 0.0)
    total = float(weights.sum())
    if total <= 0.0:
        return np.empty(0, np.int64), np.empty((0, 2), np.int64)
    sources = rng.choice(n, size=walks, p=weights / total)
    ends: list[int] = []
    edges: list[tuple[int, int]] = []
    delta = space.edge_resolution
    for v in sources.tolist():
        if budget.out_of_time():
            break
        q, node = graph.nodes[v].copy(), int(v)
        for target in space.sample_uniform(rng, BOUNCE_STEPS):
            if budget.out_of_time():  # one line's checks at most past the deadline
                break
            length = space.distance(q, target)
            steps = max(1, math.ceil(length / delta - 1e-12))
            t = np.arange(1, steps + 1) / steps
            points = space.interpolate(q, target, t)
            bad = space.first_invalid(points)
            reached = steps if bad < 0 else bad
            if reached == 0:
                continue  # blocked at once: bounce towards the next sample
            q = points[reached - 1].copy()
            child = int(graph.add_nodes(q[None, :])[0])
            edges.append((node, child))
            node = child
        if node != v:
            ends.append(node)
    space.edge_checks += len(edges)
    return np.asarray(ends, np.int64), np.asarray(edges, np.int64).reshape(-1, 2)


def _roadmap(graph: _Graph, versions: tuple[int | None, int | None], lazy: bool) -> Roadmap:
    pairs, cost, status = graph.edges()
    n = graph.n
    keep = (status > 0) | ((status == 0) if lazy else False)
    a, b, c = pairs[keep, 0], pairs[keep, 1], cost[keep]
    # both directions of each edge, grouped by node in edge order (stable sort)
    src = np.stack([a, b], axis=1).ravel()
    order = np.argsort(src, kind="stable")
    dst = np.stack([b, a], axis=1).ravel()[order]
    entries = list(zip(dst.tolist(), np.repeat(c, 2)[order].tolist()))
    ends = np.cumsum(np.bincount(src, minlength=n)).tolist()
    adjacency = [entries[lo:hi] for lo, hi in zip([0, *ends[:-1]], ends)]
    return Roadmap(
        nodes=graph.nodes[:n].copy(),
        adjacency=adjacency,
        world_version=versions[0],
        model_version=versions[1],
    )


def prm_star(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMStarOptions | None = None,
    *,
    objective: OptimizationObjective | None = None,
    rng: np.random.Generator | None = None,
) -> tuple[PlannerResult, Roadmap]:
    """Plan with PRM*: grow a roadmap with ``k_n`` nearest neighbours until the limits.

    Args:
        space: configuration space with validity checker and local planner.
        start: ``q_start`` (size d); roadmap node 0.
        goal: one goal configuration (d,), several (k, d), or a
            :class:`~taskspace.planning.GoalRegion` (one goal sample per batch; every node
            inside it is a goal).
        options: settings (batch size, ``gamma_factor``, limits).
        objective: path cost (default: Euclidean :class:`~taskspace.planning.PathLength`;
            on a joint-manifold space the length in its metric, and any objective is taken
            along its geodesics, see :mod:`~taskspace.planning.objectives`); its motion
            costs are the edge weights.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        ``(result, roadmap)``: ``result.cost`` is the objective's cost of the path, ``log``
        holds ``costs`` and ``cost_times`` (the best cost each time it improved [s]),
        ``first_solution_s``, the roadmap size and ``stopped_by``. The roadmap holds the
        collision-free edges (edge costs from the objective) and the world version.

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: bad options (see :mod:`taskspace.planning.limits`).
    """
    result, roadmap = _certified(space, start, goal, options, objective, rng, lazy=False)
    assert isinstance(roadmap, Roadmap)
    return result, roadmap


def lazy_prm_star(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMStarOptions | None = None,
    *,
    objective: OptimizationObjective | None = None,
    rng: np.random.Generator | None = None,
) -> tuple[PlannerResult, LazyRoadmap]:
    """Plan with Lazy PRM*: edges are checked only when they lie on a shortest path.

    Same arguments and results as :func:`prm_star`; the second value is a
    :class:`~taskspace.planning.LazyRoadmap` whose ``status`` says which edges were found free
    (1), colliding (-1) or never checked (0).
    """
    result, roadmap = _certified(space, start, goal, options, objective, rng, lazy=True)
    assert isinstance(roadmap, LazyRoadmap)
    return result, roadmap


def _lazy_roadmap(graph: _Graph, versions: tuple[int | None, int | None]) -> LazyRoadmap:
    pairs, cost, status = graph.edges()
    roadmap = _roadmap(graph, versions, lazy=True)
    return LazyRoadmap(roadmap=roadmap, pairs=pairs.copy(), costs=cost.copy(), status=status.copy())


def _certified(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMStarOptions | None,
    objective: OptimizationObjective | None,
    rng: np.random.Generator | None,
    lazy: bool,
) -> tuple[PlannerResult, Roadmap | LazyRoadmap]:
    """Plan once, or until a path is certified (``options.certify``, see PRMStarOptions)."""
    opts = options or PRMStarOptions()
    avoid: list[Segment] = []
    tried: list[PlannerResult] = []

    def plan(attempt: int, left: float) -> tuple[PlannerResult, Roadmap | LazyRoadmap]:
        if tried:  # its log names the segment the certificate failed on
            avoid.extend(uncertified_segment(tried[-1]))
        again = opts
        if attempt or math.isfinite(left):
            again = dataclasses.replace(
                opts,
                seed=check_seed(opts.seed) + attempt,
                time_limit_s=left if math.isfinite(left) else None,
            )
        result, graph, versions = _plan(
            space, start, goal, again, objective, rng, lazy=lazy, avoid=avoid
        )
        made = _lazy_roadmap(graph, versions) if lazy else _roadmap(graph, versions, False)
        tried.append(result)
        return result, made

    # (without certification the plan reads its limits from opts: no outer limit)
    limit = planner_limits(opts.max_iterations, opts.time_limit_s)[1] if opts.certify else math.inf
    return certify_keeping(space, plan, opts, time_limit_s=limit)
