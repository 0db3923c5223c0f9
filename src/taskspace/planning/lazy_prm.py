"""Lazy PRM (Bohlin and Kavraki, ICRA 2000; slide 3:36: "not necessary for Lazy PRMs").

The roadmap is built *without* checking edges (nodes are still free samples). A query then
repeats::

    path <- shortest path in G from q_start to q_goal (Dijkstra)
    check the unchecked edges of path (results are kept in the roadmap)
    if all are free: return path
    else: remove the colliding edges from G

until a free path is found or start and goal are disconnected. Only edges on candidate
shortest paths are ever checked, which saves most of the edge checks of a PRM. The edges of a
candidate path are checked together, coarse to fine: one checker call for the coarse points
of all of them (every colliding edge found is removed at once), then one for the remaining
full-resolution points, so a round costs one graph search (scipy) and two checker calls.

On a joint-manifold space (continuous joints, planar or floating bases) neighbours and edge
costs are in the space's metric (see :mod:`taskspace.planning.prm`), edges are its
geodesics, and :func:`lazy_prm`'s samples near the start and goal are ``q (+) sigma N(0, I)``.

Thread safety: a :class:`LazyRoadmap` is not locked and queries write the edge states they learn
back into it: query one roadmap from one thread at a time (:func:`grow_lazy_prm` returns a new
roadmap). The planners keep their other state local to the call apart from the configuration space
they are given (one space per thread).
"""

from __future__ import annotations

import logging
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from taskspace._validation import (
    MAX_INT64,
    check_count,
    check_limits,
    check_positive,
    check_seed,
    check_time_limit,
)
from taskspace.errors import InvalidInputError
from taskspace.planning.certify import certify_keeping, certify_planned
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    FloatArray,
    nested_orders,
)
from taskspace.planning.goals import REGION_FIRST_ATTEMPTS, goal_states, region_samples
from taskspace.planning.limits import (
    Budget,
    edge_case,
    edge_case_result,
    limit_log,
    result_length,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.prm import (
    PRMOptions,
    Roadmap,
    Segment,
    _candidate_pairs,
    _nearest,
    avoided_pairs,
    check_roadmap_memory,
    check_roadmap_world,
    uncertified_segment,
)
from taskspace.planning.sampling import sample_free

logger = logging.getLogger(__name__)


@dataclass
class LazyRoadmap:
    """A roadmap whose edges are checked on demand; the edge states persist across queries.

    Attributes:
        roadmap: nodes and unchecked k-nearest-neighbour edges.
        pairs: candidate edges ``(i, j)``, ``i < j``, shape (m, 2).
        costs: edge lengths ``|q_i - q_j|`` [rad or m], shape (m,).
        status: per edge 0 = not checked, 1 = free at the full resolution, -1 = in collision.
    """

    roadmap: Roadmap
    pairs: npt.NDArray[np.int64] = field(default_factory=lambda: np.empty((0, 2), np.int64))
    costs: FloatArray = field(default_factory=lambda: np.empty(0))
    status: npt.NDArray[np.int8] = field(default_factory=lambda: np.empty(0, np.int8))

    @property
    def valid(self) -> dict[tuple[int, int], bool]:
        """Edges checked so far: ``(i, j) -> free``."""
        done = np.flatnonzero(self.status != 0)
        return {
            (int(self.pairs[e, 0]), int(self.pairs[e, 1])): bool(self.status[e] > 0) for e in done
        }


def _empty_roadmap(space: ConfigurationSpace) -> Roadmap:
    """A roadmap without nodes, of the space's current world and limits (queries accept it)."""
    return Roadmap(
        nodes=np.empty((0, space.dim)),
        adjacency=[],
        world_version=space.world_version,
        model_version=space.model_version,
    )


def build_lazy_prm(
    space: ConfigurationSpace,
    options: PRMOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> LazyRoadmap:
    """Sample free nodes and connect k nearest neighbours without checking the edges.

    Raises:
        InvalidInputError: invalid options, or a roadmap too large for the machine's memory
            (:func:`~taskspace.planning.prm.check_roadmap_memory`, before allocating).
    """
    opts = options or PRMOptions()
    n_samples = opts.roadmap_size()
    k = check_count(opts.k_neighbors, "k_neighbors", minimum=1)
    check_roadmap_memory(n_samples, space.dim, k)
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    t0 = time.perf_counter()
    checks0 = space.checks
    nodes = sample_free(space, n_samples, rng, strategy=opts.sampler, sigma=opts.sigma)
    pairs = _candidate_pairs(nodes, opts.k_neighbors, space)
    costs = space.distances(nodes[pairs[:, 1]], nodes[pairs[:, 0]])
    adjacency: list[list[tuple[int, float]]] = [[] for _ in range(nodes.shape[0])]
    for (i, j), c in zip(pairs.tolist(), costs.tolist()):
        adjacency[i].append((j, c))
        adjacency[j].append((i, c))
    roadmap = Roadmap(
        nodes=nodes,
        adjacency=adjacency,
        build_time_s=time.perf_counter() - t0,
        collision_checks=space.checks - checks0,
        edges_tried=0,
        world_version=space.world_version,
        model_version=space.model_version,
    )
    return LazyRoadmap(
        roadmap=roadmap, pairs=pairs, costs=costs, status=np.zeros(len(costs), dtype=np.int8)
    )


def _edge_points(
    space: ConfigurationSpace, q0: FloatArray, q1: FloatArray, stride: int, coarse: bool
) -> FloatArray:
    """Coarse-pass or fine-pass interior points of the segment ``q0 -> q1`` (nested orders)."""
    n = space.segments(q0, q1)
    first, second = nested_orders(n, stride)
    idx = first if coarse else second
    return space.interpolate(q0, q1, idx / n)


def _check_edges(
    space: ConfigurationSpace,
    ends: list[tuple[FloatArray, FloatArray]],
    stride: int,
    *,
    complete: bool = False,
) -> npt.NDArray[np.bool_]:
    """Which segments are free at the full resolution: coarse pass on all, then fine pass.

    A segment with a colliding coarse point is not fine-checked; every point is checked at
    most once. Segment end points are assumed free. Unless ``complete``, the fine pass is
    skipped when a coarse point collided (the returned True then only means "coarse free").
    """
    free = np.ones(len(ends), dtype=bool)
    for coarse in (True, False):
        todo = np.flatnonzero(free)
        chunks = [_edge_points(space, *ends[e], stride, coarse) for e in todo]
        sizes = np.array([c.shape[0] for c in chunks])
        if sizes.sum() == 0:
            continue
        ok = space.checker.are_valid(np.vstack(chunks))
        owner = np.repeat(todo, sizes)
        free[np.unique(owner[~ok])] = False
        if coarse and not complete and not free.all():
            break  # some edges failed: the caller searches again before fine checks
    return free


COARSE_RESOLUTION = 0.15
"""Default first-pass resolution of :func:`lazy_prm_query` [rad or m]."""

_FROM_OPTIONS: Any = object()
"""Default of the ``time_limit_s`` keywords: take ``PRMOptions.time_limit_s``."""


def _time_limit(keyword: Any, options: PRMOptions | None, default: float | None, who: str) -> Any:
    """The time limit of a lazy PRM call: the keyword, else the options', else ``default``.

    ``PRMOptions.time_limit_s`` was silently ignored by these functions (their keyword's
    default won); a keyword and options that disagree are refused.
    """
    from_options = options.time_limit_s if options is not None else None
    if keyword is _FROM_OPTIONS:
        return from_options if from_options is not None else default
    if from_options is not None and not (
        isinstance(keyword, (int, float)) and float(keyword) == float(from_options)
    ):
        raise InvalidInputError(
            f"{who}: time_limit_s={keyword!r} and options.time_limit_s={from_options!r} "
            "disagree; give the time limit once"
        )
    return keyword


def lazy_prm_query(
    space: ConfigurationSpace,
    lazy: LazyRoadmap,
    start: Any,
    goal: Any,
    options: PRMOptions | None = None,
    *,
    time_limit_s: Any = _FROM_OPTIONS,
    coarse_resolution: float = COARSE_RESOLUTION,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Answer a query on a lazy roadmap, checking only edges of candidate shortest paths.

    Each round: shortest path from ``q_start`` to the nearest goal over the edges not known
    to collide (scipy's Dijkstra on the sparse graph; start and goals are joined to their k
    nearest nodes and to each other); its unchecked edges are checked together, first at
    ``coarse_resolution`` (every colliding edge found is removed, and the search is redone),
    then at the full resolution. The path is returned when all its edges are free, so it is
    the shortest path of the fully checked roadmap (the PRM's answer, slide 3:30). Edge
    states are stored in ``lazy`` and reused by later queries.

    Args:
        space: the configuration space of the roadmap.
        lazy: from :func:`build_lazy_prm` (its edge states are updated).
        start: ``q_start``.
        goal: ``q_goal``, several goal configurations (k, d), or a
            :class:`~taskspace.planning.GoalRegion` (its valid samples among 20 are the goal
            states; a start inside it is a one-point path): see
            :mod:`taskspace.planning.goals`. The path ends at the goal of the shortest path.
        options: ``k_neighbors`` and ``time_limit_s`` are used (``seed`` for a region).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf``: none; every round
            removes an edge or ends, so the query ends without one); left out:
            ``options.time_limit_s``. Given both, they must agree.
        coarse_resolution: first-pass resolution [rad or m].
        rng: random generator of a region's samples (default: from ``options.seed``).

    Raises:
        PlanningError: start or goal outside the bounds or in collision; the roadmap was
            built for another version of the obstacle world (its edge states are stale).
        InvalidInputError: a NaN or negative time limit, a bad resolution; ``certify`` on a
            space without a robot.

    Certified paths: with ``options.certify`` the path is proven free between its checked
    points (:func:`~taskspace.planning.certify.certify_planned`, within the time limit):
    ``log`` has ``certified``, ``min_distance`` [m] and ``certify_attempts``; an uncertified
    path is searched again without the segment that failed (``certify_retries`` times; the
    edges keep the state the resolution check gave) and, if none can be certified, the
    result has ``success=False``, status ``UNCERTIFIED`` and the failing segment in ``log``.
    """
    opts = options or PRMOptions()
    time_limit_s = _time_limit(time_limit_s, options, None, "lazy_prm_query")
    limit = check_time_limit(time_limit_s)
    check_positive(coarse_resolution, "coarse_resolution")
    avoid: list[Segment] = []
    tried: list[PlannerResult] = []

    def plan(attempt: int, left: float) -> PlannerResult:
        if tried:  # its log names the segment the certificate failed on
            avoid.extend(uncertified_segment(tried[-1]))
        tried.append(_query(space, lazy, start, goal, opts, left, coarse_resolution, rng, avoid))
        return tried[-1]

    if not opts.certify:
        return plan(0, limit)
    return certify_planned(
        space,
        plan,
        time_limit_s=limit,
        retries=opts.certify_retries,
        tolerance=opts.certify_tolerance,
    )


def _query(
    space: ConfigurationSpace,
    lazy: LazyRoadmap,
    start: Any,
    goal: Any,
    opts: PRMOptions,
    time_limit: float,
    coarse_resolution: float,
    rng: np.random.Generator | None,
    avoid: Sequence[Segment] = (),
) -> PlannerResult:
    """:func:`lazy_prm_query` without certification, under ``time_limit`` [s].

    The segments of ``avoid`` (those whose certificate failed) are not used.
    """
    t0 = time.perf_counter()
    deadline = t0 + time_limit
    checks0, edges0 = space.checks, space.edge_checks
    check_roadmap_world(space, lazy.roadmap)
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    if region is not None:
        rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
        goals = region_samples(space, region, rng, REGION_FIRST_ATTEMPTS, deadline)
    roadmap = lazy.roadmap
    n = roadmap.size
    s = n
    targets = np.arange(n + 1, n + 1 + len(goals))
    kk = min(opts.k_neighbors, n)
    stride = max(1, math.floor(coarse_resolution / space.edge_resolution + 1e-9))
    points = np.vstack([roadmap.nodes, q_start, *goals])
    extra_pairs = [[s, int(g)] for g in targets]
    for v in [s, *targets.tolist()]:
        if kk == 0:
            break
        if space.is_euclidean:
            _, idx = roadmap.kdtree.query(points[v], k=kk)
        else:
            _, idx = _nearest(space, roadmap.nodes, points[v], kk)
        extra_pairs += [[min(v, j), max(v, j)] for j in np.atleast_1d(idx).tolist()]
    extra = np.asarray(extra_pairs, dtype=np.int64).reshape(-1, 2)
    pairs = np.vstack([lazy.pairs, extra])
    costs = np.concatenate([lazy.costs, space.distances(points[extra[:, 1]], points[extra[:, 0]])])
    status = np.concatenate([lazy.status, np.zeros(len(extra), dtype=np.int8)])
    index = {(int(a), int(b)): e for e, (a, b) in enumerate(pairs.tolist())}
    usable = np.ones(len(pairs), dtype=bool)
    for pair in avoided_pairs(points, avoid) if avoid else ():
        if pair in index:
            usable[index[pair]] = False
    m = len(lazy.costs)
    status_out = PlannerStatus.NO_PATH
    ids: list[int] = []
    rounds = 0
    size = points.shape[0]
    if region is not None and region.contains(q_start):
        ids, status_out = [s], PlannerStatus.SOLVED
    while not ids and targets.size:
        if time.perf_counter() > deadline:
            status_out = PlannerStatus.TIME_LIMIT
            break
        rounds += 1
        keep = status >= 0
        if avoid:
            keep &= usable
        # Zero-length edges would vanish from the sparse matrix: give them a tiny cost.
        weights = np.maximum(costs[keep], 1e-12)
        graph = csr_matrix((weights, (pairs[keep, 0], pairs[keep, 1])), shape=(size, size))
        dist, pred = dijkstra(graph, directed=False, indices=s, return_predecessors=True)
        g = int(targets[np.argmin(dist[targets])])
        if not np.isfinite(dist[g]):
            status_out = PlannerStatus.NO_PATH
            break
        ids = [g]
        while ids[-1] != s:
            ids.append(int(pred[ids[-1]]))
        ids.reverse()
        path_edges = [index[(min(a, b), max(a, b))] for a, b in zip(ids[:-1], ids[1:])]  # noqa: RUF007
        unknown = [e for e in path_edges if status[e] == 0]
        if not unknown:
            status_out = PlannerStatus.SOLVED
            break
        space.edge_checks += len(unknown)
        ends = [(points[pairs[e, 0]], points[pairs[e, 1]]) for e in unknown]
        free = _check_edges(space, ends, stride)
        bad = [e for e, ok in zip(unknown, free) if not ok]
        for e in bad:
            status[e] = -1
        if not bad:
            for e in unknown:
                status[e] = 1
        ids = []
    lazy.status[:] = status[:m]  # roadmap edge states are kept for later queries
    success = status_out is PlannerStatus.SOLVED
    path = points[ids] if success else np.empty((0, space.dim))
    length = result_length(space, path, success)
    dt = time.perf_counter() - t0
    return PlannerResult(
        success=success,
        status=status_out,
        path=path,
        path_length=length,
        iterations=rounds,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=dt,
        log={
            "search_rounds": float(rounds),
            "roadmap_nodes": float(roadmap.size),
            "goal_states": float(len(goals)),
            **limit_log(status_out, length, dt),
        },
    )


def grow_lazy_prm(
    space: ConfigurationSpace, lazy: LazyRoadmap, new_nodes: FloatArray, k: int
) -> LazyRoadmap:
    """Add nodes to a lazy roadmap; edge states of edges that stay candidates are kept.

    The k-nearest-neighbour candidate edges are recomputed over all nodes (old node indices are
    unchanged, new nodes are appended).
    """
    old = lazy.roadmap
    if old.size:
        check_roadmap_world(space, old)
    nodes = np.vstack([old.nodes, new_nodes]) if new_nodes.shape[0] else old.nodes
    pairs = _candidate_pairs(nodes, k, space)
    costs = space.distances(nodes[pairs[:, 1]], nodes[pairs[:, 0]])
    status = np.zeros(len(costs), dtype=np.int8)
    known = {(int(a), int(b)): int(st) for (a, b), st in zip(lazy.pairs.tolist(), lazy.status)}
    for e, (a, b) in enumerate(pairs.tolist()):
        status[e] = known.get((a, b), 0)
    adjacency: list[list[tuple[int, float]]] = [[] for _ in range(nodes.shape[0])]
    for (i, j), c in zip(pairs.tolist(), costs.tolist()):
        adjacency[i].append((j, c))
        adjacency[j].append((i, c))
    roadmap = Roadmap(
        nodes=nodes,
        adjacency=adjacency,
        build_time_s=old.build_time_s,
        collision_checks=old.collision_checks,
        edges_tried=old.edges_tried,
        world_version=space.world_version if old.size == 0 else old.world_version,
        model_version=space.model_version if old.size == 0 else old.model_version,
    )
    return LazyRoadmap(roadmap=roadmap, pairs=pairs, costs=costs, status=status)


def _one_point(q: FloatArray) -> PlannerResult:
    """The path of a start inside the goal region."""
    return PlannerResult(
        success=True,
        status=PlannerStatus.SOLVED,
        path=q[None, :].copy(),
        path_length=0.0,
        iterations=0,
        collision_checks=0,
        edge_checks=0,
        time_s=0.0,
    )


_UNSET: Any = object()
"""Default of the deprecated ``max_rounds`` keyword: not given."""

_ROUNDS = 100
"""Growth rounds of :func:`lazy_prm` under the deprecated ``n_samples`` without ``max_rounds``."""


def lazy_prm(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMOptions | None = None,
    *,
    time_limit_s: Any = _FROM_OPTIONS,
    max_rounds: Any = _UNSET,
    endpoint_fraction: float = 0.2,
    rng: np.random.Generator | None = None,
) -> tuple[PlannerResult, LazyRoadmap]:
    """Single-query Lazy PRM that grows its roadmap until start and a goal are connected.

    Round ``r`` adds ``batch_size`` free nodes: a fraction ``endpoint_fraction`` drawn from
    ``N(q_start, sigma^2 I)`` and ``N(q_goal, sigma^2 I)`` around the start and the goals
    (the tight start and goal regions of manipulation problems), the rest uniform; then
    :func:`lazy_prm_query` runs on the grown roadmap (edge states carried over). Stops when a
    path is found, after ``max_iterations`` samples or when the time runs out.

    Threads: Python code (the GIL runs one thread at a time; Ctrl-C interrupts it). Plans in
    several threads give the results of sequential runs when each thread has its own space
    (checker) and ``rng``; a compiled checker shared by threads is locked, a space's counters
    and a Python checker are not.

    Args:
        space: the configuration space.
        start: ``q_start``.
        goal: ``q_goal``, several goal configurations (k, d), or a
            :class:`~taskspace.planning.GoalRegion` (:mod:`taskspace.planning.goals`: its
            valid samples among 20 are goal states, one more sample each round, up to 32;
            a start inside it is a one-point path). The path ends at one of the goals.
        options: ``max_iterations`` (samples in all rounds, ``None``: no cap),
            ``batch_size`` (nodes added per round), ``k_neighbors``, ``sigma``, ``seed``,
            ``time_limit_s`` (``None``: no time limit, as for every planner of
            :mod:`taskspace.planning.limits`). Left out: no sample cap and a 1 s time limit.
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf``: none, then
            ``max_iterations`` must be an integer); left out: ``options.time_limit_s``, or
            1 s when ``options`` is left out too. Given both, they must agree. Changed: with
            ``options`` given, ``options.time_limit_s=None`` meant 1 s; it now means no
            time limit (a ``DeprecationWarning`` says so; with no sample cap either, the
            old 1 s is kept, with a ``DeprecationWarning``, until it is refused as for the
            other planners).
        max_rounds: deprecated (``DeprecationWarning``): a cap of ``max_rounds`` growth
            rounds, i.e. ``max_rounds * batch_size`` samples (``None``: none).
        endpoint_fraction: fraction of each round's nodes drawn near start and goals.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        ``(result, lazy roadmap)``; ``time_s`` and ``collision_checks`` include construction;
        ``iterations`` counts the samples; status ``ITERATION_LIMIT`` after
        ``max_iterations`` samples without a path; ``log`` has ``growth_rounds``,
        ``stopped_by``, ``costs`` and ``cost_times`` (:mod:`taskspace.planning.limits`).

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: a NaN or negative time limit, no limit at all
            (``max_iterations`` and ``time_limit_s`` both ``None``), bad options;
            ``certify`` on a space without a robot.

    Certified paths: with ``options.certify`` the path is proven free between its checked
    points by :func:`~taskspace.planning.certify_path` (``log``: ``certified``,
    ``min_distance`` [m], ``certify_attempts``); an uncertified path is re-planned from a new
    roadmap (seeds ``seed + 1``, ... or the next draws of ``rng``; ``certify_retries``
    times, within the time limit, which covers the certification) and, if none can be
    certified, the result has ``success=False``, status ``UNCERTIFIED`` and the failing
    segment in ``log``; the lazy roadmap returned is the last one grown. A re-plan does not
    use the segments whose certificate failed (the straight line, a start or goal edge
    would otherwise be passed and taken again).
    """
    opts = options or PRMOptions(max_iterations=None)
    unset = time_limit_s is _FROM_OPTIONS and options is not None and opts.time_limit_s is None
    time_limit_s = _time_limit(time_limit_s, options, None if options else 1.0, "lazy_prm")
    if opts.n_samples is not None:  # deprecated: nodes per round, rounds capped by max_rounds
        batch = check_count(opts.n_samples, "n_samples", minimum=1)
        rounds_cap = _ROUNDS
    else:
        batch = check_count(opts.batch_size, "batch_size", minimum=1)
        rounds_cap = None
    names = ("max_iterations", "time_limit_s")
    cap_in: Any = opts.max_iterations
    if max_rounds is not _UNSET:
        warnings.warn(
            "lazy_prm(max_rounds=...) is deprecated: use PRMOptions(max_iterations=...) "
            "(samples in all rounds; batch_size samples per round)",
            DeprecationWarning,
            stacklevel=2,
        )
        rounds_cap = max_rounds
        names = ("max_rounds", "time_limit_s")
    if rounds_cap is not None or max_rounds is not _UNSET:
        cap_in = rounds_cap
    if unset and cap_in is None:
        # PRMOptions.time_limit_s=None meant 1 s here; with no sample cap either, it would
        # now be refused (no limit at all) as by every planner: keep the 1 s, warn.
        warnings.warn(
            "lazy_prm: PRMOptions(time_limit_s=None) with no sample cap ran for 1 s; "
            "time_limit_s=None means no time limit for every planner, so this will be "
            "refused like theirs: give time_limit_s (e.g. 1.0) or max_iterations",
            DeprecationWarning,
            stacklevel=2,
        )
        time_limit_s = 1.0
    elif unset:
        warnings.warn(
            "lazy_prm: PRMOptions(time_limit_s=None) now means no time limit, as for every "
            "planner (it meant 1 s): the run is capped by max_iterations samples only; give "
            "time_limit_s=1.0 for the old limit (math.inf: none, without this warning)",
            DeprecationWarning,
            stacklevel=2,
        )
    minimum = 1 if names[0] == "max_rounds" else 0
    cap, limit = check_limits(cap_in, time_limit_s, names=names, minimum=minimum)
    if names[0] == "max_rounds" or opts.n_samples is not None:
        cap = None if cap is None else cap * batch  # rounds -> samples
    if not 0.0 <= endpoint_fraction <= 1.0:
        raise InvalidInputError(f"endpoint_fraction must be in [0, 1], got {endpoint_fraction}")
    check_count(opts.k_neighbors, "k_neighbors", minimum=1)
    seed = check_seed(opts.seed)
    avoid: list[Segment] = []
    tried: list[PlannerResult] = []

    def plan(attempt: int, left: float) -> tuple[PlannerResult, LazyRoadmap]:
        if tried:  # its log names the segment the certificate failed on
            avoid.extend(uncertified_segment(tried[-1]))
        generator = rng if rng is not None else np.random.default_rng(seed + attempt)
        result, lazy = _grow(
            space, start, goal, opts, cap, batch, left, endpoint_fraction, generator, avoid
        )
        tried.append(result)
        return result, lazy

    return certify_keeping(space, plan, opts, time_limit_s=limit)


def _grow(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: PRMOptions,
    cap: int | None,
    batch: int,
    limit: float,
    endpoint_fraction: float,
    rng: np.random.Generator,
    avoid: Sequence[Segment] = (),
) -> tuple[PlannerResult, LazyRoadmap]:
    """:func:`lazy_prm` without certification: at most ``cap`` samples in ``limit`` [s].

    The segments of ``avoid`` (those whose certificate failed) are not used.
    """
    t0 = time.perf_counter()
    deadline = t0 + limit
    checks0, edges0 = space.checks, space.edge_checks
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    if region is not None:
        goals = region_samples(space, region, rng, REGION_FIRST_ATTEMPTS, deadline)
    budget = Budget(MAX_INT64 if cap is None else cap, limit, t0)
    found = edge_case(space, q_start, goals, region, budget)
    if found is not None:
        empty = LazyRoadmap(roadmap=_empty_roadmap(space))
        early = edge_case_result(space, found, budget, (checks0, edges0), goal_count=len(goals))
        early.log["growth_rounds"] = 0.0
        return early, empty
    query_opts = PRMOptions(
        max_iterations=1, k_neighbors=opts.k_neighbors, seed=check_seed(opts.seed)
    )
    lazy: LazyRoadmap | None = None
    rounds = samples = 0
    result: PlannerResult | None = None
    if region is not None and region.contains(q_start):
        result = _one_point(q_start)
    while result is None or not result.success:
        if cap is not None and samples >= cap:
            if result is not None:
                result.status = PlannerStatus.ITERATION_LIMIT
            break
        if rounds and time.perf_counter() > deadline:  # (edge_case read it before the first)
            if result is not None:
                result.status = PlannerStatus.TIME_LIMIT
            break
        rounds += 1
        m = batch if cap is None else min(batch, cap - samples)
        samples += m
        if region is not None and len(goals) < 32:
            goals += region_samples(space, region, rng, 1, deadline)
        centres = [q_start, *goals]
        n_end = int(endpoint_fraction * m) // 2
        per_goal = -(-n_end // max(1, len(goals))) if goals else 0
        near = []
        for which, q in enumerate(centres):
            count = n_end if which == 0 else per_goal
            if count == 0:
                continue
            if space.is_euclidean:
                cand = np.clip(
                    q + opts.sigma * rng.standard_normal((4 * count, space.dim)),
                    space.lower,
                    space.upper,
                )
            else:  # q (+) sigma N(0, I) on the manifold, inside the bounds
                steps = opts.sigma * rng.standard_normal((4 * count, space.tangent_dim))
                moved = [space.retract(q, v) for v in steps]
                cand = np.array([c for c in moved if space.within_bounds(c)]).reshape(-1, space.dim)
            near.append(cand[space.checker.are_valid(cand)][:count])
        near_count = sum(a.shape[0] for a in near)
        uniform = sample_free(space, max(0, m - n_end - min(n_end, per_goal * len(goals))), rng)
        fresh = np.vstack([*near, uniform]) if near_count or uniform.size else uniform
        if lazy is None:
            base = _empty_roadmap(space)
            lazy = LazyRoadmap(roadmap=base)
        lazy = grow_lazy_prm(space, lazy, fresh, opts.k_neighbors)
        if not goals:  # a region none of whose samples was valid yet
            continue
        remaining = math.inf if math.isinf(limit) else max(0.0, deadline - time.perf_counter())
        result = _query(
            space,
            lazy,
            q_start,
            np.asarray(goals),
            query_opts,
            remaining,
            COARSE_RESOLUTION,
            None,
            avoid,
        )
    if lazy is None:  # no round ran (no samples allowed, or no time)
        lazy = LazyRoadmap(roadmap=_empty_roadmap(space))
    if result is None:  # no query ran
        result = PlannerResult(
            success=False,
            status=PlannerStatus.ITERATION_LIMIT
            if cap is not None and samples >= cap
            else PlannerStatus.TIME_LIMIT,
            path=np.empty((0, space.dim)),
            path_length=math.inf,
            iterations=0,
            collision_checks=0,
            edge_checks=0,
            time_s=0.0,
        )
    result.time_s = time.perf_counter() - t0
    result.iterations = samples
    result.collision_checks = space.checks - checks0
    result.edge_checks = space.edge_checks - edges0
    result.log["growth_rounds"] = float(rounds)
    result.log["goal_states"] = float(len(goals))
    result.log.update(limit_log(result.status, result.path_length, result.time_s))
    return result, lazy
