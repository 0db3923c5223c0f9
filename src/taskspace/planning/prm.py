"""Probabilistic roadmaps (slides 3:28-3:36; Kavraki, Svestka, Latombe, Overmars 1996).

Generation (slide 3:31)::

    V <- n free samples (uniform, Gaussian or bridge sampling, slide 3:35)
    for q in V:
        for q' in the k nearest neighbours of q in V:      (KD-tree, scipy cKDTree)
            if the straight segment q -> q' is in Q_free:  E <- E + {(q, q')}

A query (slide 3:30) connects ``q_start`` and ``q_goal`` to their k nearest roadmap nodes with
the same local planner and runs Dijkstra (or A* with the Euclidean distance to the goal as
admissible heuristic) on the graph with edge cost ``|q - q'|``. The roadmap is not modified
by queries, so one roadmap answers many queries (slide 3:36).

On a joint-manifold space (continuous joints, planar or floating bases) the neighbours, edge
costs and the A* heuristic are in the space's metric (nearest neighbours by a scan instead of
the KD-tree, ``O(n^2)`` distance evaluations for ``n`` nodes), edges are the space's
geodesics, and only uniform sampling is available.

Thread safety: :class:`PRMOptions` is immutable; a :class:`Roadmap` is only read by queries (its
KD-tree is built on first use; threads racing on it build equal trees), so threads may query one
roadmap, each with its own configuration space, as long as nobody modifies it. The planners keep
their other state local to the call.
"""

from __future__ import annotations

import logging
import math
import os
import time
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from taskspace._validation import MAX_INT64, check_count, check_seed, check_time_limit
from taskspace.errors import InvalidInputError, PlanningError, StaleModelError
from taskspace.planning.certify import certify_keeping, certify_planned
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray
from taskspace.planning.goals import REGION_FIRST_ATTEMPTS, goal_states, region_samples
from taskspace.planning.graph_search import astar, dijkstra
from taskspace.planning.limits import Budget, limit_log, result_length
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.sampling import Sampler, _candidates, sample_free

logger = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class PRMOptions:
    """Settings of :func:`build_prm`, :func:`prm_query` and the Lazy PRM functions.

    Attributes:
        max_iterations: samples (one iteration = one free sample, as for every planner of
            :mod:`taskspace.planning.limits`): the roadmap's nodes ``n`` for
            :func:`build_prm`, :func:`prm` and :func:`~taskspace.planning.build_lazy_prm`
            (an integer >= 0; 0: an empty roadmap, only the straight line is checked); for
            :func:`~taskspace.planning.lazy_prm`, the samples of all
            its growth rounds (``None``: no cap, then the time limit must be finite).
        k_neighbors: neighbours ``k`` tried per node (slide 3:31).
        sampler: ``"uniform"``, ``"gaussian"`` or ``"bridge"`` (slide 3:35).
        sigma: standard deviation of Gaussian/bridge offsets [rad or m].
        search: ``"dijkstra"`` or ``"astar"`` for queries.
        seed: random seed used when no ``rng`` is passed.
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf``: none; NaN refused).
            :func:`build_prm` stops sampling and connecting at it (:attr:`Roadmap.timed_out`),
            :func:`prm_query` stops its edge checks at it, and :func:`prm` (one deadline for
            both) then reports ``TIME_LIMIT`` when no path is found.
        batch_size: samples added per growth round of :func:`~taskspace.planning.lazy_prm`.
        n_samples: deprecated name (a ``DeprecationWarning``): for :func:`build_prm`,
            :func:`prm` and :func:`~taskspace.planning.build_lazy_prm` it is
            ``max_iterations``; for :func:`~taskspace.planning.lazy_prm` it is
            ``batch_size`` (nodes per round, as before). ``None``: not given.
        certify: :func:`prm`, :func:`prm_query`, :func:`~taskspace.planning.lazy_prm` and
            :func:`~taskspace.planning.lazy_prm_query` prove the returned path free between
            its checked points (:func:`~taskspace.planning.certify_path`, conservative
            advancement on the robot's geometry; needs a space built on a robot) within
            ``time_limit_s``; a path that cannot be certified gives ``success=False`` and
            status ``UNCERTIFIED``. They first plan again ``certify_retries`` times without
            the segments whose certificate failed: :func:`prm` and
            :func:`~taskspace.planning.lazy_prm` with a new roadmap (the next seeds), the
            queries on the same roadmap.
        certify_retries: re-plans after an uncertified path (:func:`prm`,
            :func:`~taskspace.planning.lazy_prm`: the next seeds; the queries: the same
            roadmap), each without the segments that failed before.
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
    """

    max_iterations: int | None = 500
    k_neighbors: int = 10
    sampler: Sampler = "uniform"
    sigma: float = 0.3
    search: Literal["dijkstra", "astar"] = "dijkstra"
    seed: int = 0
    time_limit_s: float | None = None
    batch_size: int = 500
    n_samples: int | None = None
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4

    def __post_init__(self) -> None:
        if self.n_samples is not None:
            warnings.warn(
                "PRMOptions.n_samples is deprecated: use max_iterations (the roadmap's "
                "samples; for lazy_prm, batch_size: the samples per growth round)",
                DeprecationWarning,
                stacklevel=3,
            )

    def roadmap_size(self) -> int:
        """The nodes of a roadmap built at once (``n_samples`` if given, else ``max_iterations``).

        ``0`` is an empty roadmap (:func:`prm` then only checks the straight line, see
        :mod:`taskspace.planning.limits`).

        Raises:
            InvalidInputError: not an integer >= 0 (a roadmap built at once needs its size).
        """
        n = self.n_samples if self.n_samples is not None else self.max_iterations
        if n is None:
            raise InvalidInputError(
                "max_iterations=None: a roadmap built at once (build_prm, prm, build_lazy_prm) "
                "needs its number of samples; give max_iterations an integer >= 0"
            )
        return check_count(n, "max_iterations", minimum=0)


@dataclass
class Roadmap:
    """A roadmap ``G = (V, E)``.

    Attributes:
        nodes: configurations, shape (n, d).
        adjacency: ``adjacency[i]`` lists ``(j, cost)`` with ``cost = |q_i - q_j|``.
        build_time_s: construction time [s].
        collision_checks: configurations evaluated while building.
        edges_tried: local-planner queries while building.
        world_version: :attr:`ConfigurationSpace.world_version` of the world the edges were
            checked in (``None`` without a world); queries refuse a roadmap whose version
            differs from the space's.
        model_version: :attr:`ConfigurationSpace.model_version` of the robot limits the
            nodes were sampled in (``None``: a space not built on a robot); queries refuse a
            roadmap whose version differs (after :meth:`Robot.set_limits` its nodes may be
            outside the new limits).
        timed_out: the time limit stopped the construction before all ``max_iterations``
            samples were drawn and connected (the nodes are those connected in time; the edges
            of the last round not tried in time are missing).
    """

    nodes: FloatArray
    adjacency: list[list[tuple[int, float]]]
    build_time_s: float = 0.0
    collision_checks: int = 0
    edges_tried: int = 0
    world_version: int | None = None
    model_version: int | None = None
    timed_out: bool = False
    _tree: Any = field(default=None, repr=False)

    @property
    def size(self) -> int:
        """Number of nodes."""
        return int(self.nodes.shape[0])

    @property
    def edges(self) -> npt.NDArray[np.int64]:
        """Undirected edges ``(i, j)`` with ``i < j``, shape (m, 2)."""
        pairs = [(i, j) for i, nb in enumerate(self.adjacency) for j, _ in nb if i < j]
        return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)

    @property
    def kdtree(self) -> Any:
        """KD-tree over the nodes (built on first use)."""
        if self._tree is None:
            self._tree = cKDTree(self.nodes)
        return self._tree

    def components(self) -> npt.NDArray[np.int64]:
        """Connected-component label of every node."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        e = self.edges
        n = self.size
        mat = coo_matrix((np.ones(e.shape[0]), (e[:, 0], e[:, 1])), shape=(n, n))
        return np.asarray(connected_components(mat, directed=False)[1], dtype=np.int64)


def check_roadmap_world(space: ConfigurationSpace, roadmap: Roadmap) -> None:
    """Refuse a roadmap whose edges were checked in another version of the obstacle world.

    Also refuses a roadmap sampled in other robot limits (:attr:`Roadmap.model_version`).

    Raises:
        StaleModelError: ``roadmap.model_version`` differs from ``space.model_version``
            (:meth:`Robot.set_limits` or :meth:`Robot.edit_model` was called since the
            roadmap was built): its nodes and edges may be outside the new limits or collide;
            build a new roadmap.
        PlanningError: ``roadmap.world_version`` differs from ``space.world_version`` (an
            obstacle was added, removed or moved, or the collision pairs changed since the
            roadmap was built): its edges may now collide; build a new roadmap.
    """
    model_now = space.model_version
    if roadmap.model_version != model_now:
        raise StaleModelError(
            f"the roadmap was built for version {roadmap.model_version} of the robot's limits "
            f"but the space is now at version {model_now} (Robot.set_limits or "
            "Robot.edit_model): its nodes may "
            "be outside the new limits; build a new roadmap (build_prm / build_lazy_prm / "
            "prm_star) for the current limits",
            -1 if roadmap.model_version is None else roadmap.model_version,
            -1 if model_now is None else model_now,
        )
    now = space.world_version
    if roadmap.world_version != now:
        raise PlanningError(
            f"the roadmap was built for world version {roadmap.world_version} but the space's "
            f"world is now at version {now} (obstacles or collision pairs changed): its edges "
            "may collide; build a new roadmap (build_prm / build_lazy_prm / prm_star) for the "
            "current world"
        )


def _nearest(
    space: ConfigurationSpace | None, nodes: FloatArray, q: FloatArray, k: int
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Distances and indices of the ``k`` nodes nearest to ``q`` in the space's metric.

    A KD-tree in a Euclidean space; a scan of ``space.distances`` on a joint manifold.
    """
    if space is None or space.is_euclidean:
        dist, idx = cKDTree(nodes).query(q, k=k)
        return np.atleast_1d(dist), np.atleast_1d(idx).astype(np.int64)
    d = space.distances(nodes, q)
    idx = np.argsort(d, kind="stable")[:k]
    return d[idx], idx.astype(np.int64)


Segment = tuple[FloatArray, FloatArray]
"""A straight segment ``(q_a, q_b)`` between two configurations (either direction)."""


def uncertified_segment(result: PlannerResult) -> list[Segment]:
    """The segment of ``result.path`` its certificate failed on (``[]`` when none did).

    Read from ``log["uncertified_segment"]`` (:func:`~taskspace.planning.certify.certify_planned`):
    a re-plan avoids it, since the edge check passed it and would pass it again.
    """
    if result.log.get("certified") != 0.0 or "uncertified_segment" not in result.log:
        return []
    s = int(result.log["uncertified_segment"])
    if not 0 <= s < result.path.shape[0] - 1:
        return []
    return [(result.path[s].copy(), result.path[s + 1].copy())]


def avoided_pairs(points: FloatArray, avoid: Sequence[Segment]) -> set[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, of ``points`` joined by a segment of ``avoid``."""
    out: set[tuple[int, int]] = set()
    for a, b in avoid:
        at_a = np.flatnonzero(np.all(points == a, axis=1)).tolist()
        at_b = np.flatnonzero(np.all(points == b, axis=1)).tolist()
        out.update((min(i, j), max(i, j)) for i in at_a for j in at_b if i != j)
    return out


def _avoids(avoid: Sequence[Segment], a: FloatArray, b: FloatArray) -> bool:
    """Whether the segment ``a -> b`` is one of ``avoid`` (either direction)."""
    return any(
        (np.array_equal(a, p) and np.array_equal(b, q))
        or (np.array_equal(a, q) and np.array_equal(b, p))
        for p, q in avoid
    )


def _candidate_pairs(
    nodes: FloatArray, k: int, space: ConfigurationSpace | None = None
) -> npt.NDArray[np.int64]:
    """Unique undirected pairs (i, j), i < j, from the k nearest neighbours of every node.

    Neighbours in the space's metric when ``space`` is a joint-manifold space.
    """
    n = nodes.shape[0]
    if n < 2 or k < 1:
        return np.empty((0, 2), dtype=np.int64)
    kk = min(k + 1, n)
    if space is None or space.is_euclidean:
        _, idx = cKDTree(nodes).query(nodes, k=kk)
    else:
        idx = np.array([_nearest(space, nodes, q, kk)[1] for q in nodes])
    idx = np.asarray(idx).reshape(n, kk)[:, 1:]
    rows = np.repeat(np.arange(n), idx.shape[1])
    pairs = np.stack([rows, idx.ravel()], axis=1)
    pairs = np.sort(pairs, axis=1)
    return np.unique(pairs, axis=0)


def connect_roadmap(
    space: ConfigurationSpace,
    nodes: FloatArray,
    k: int,
    *,
    check_edges: bool = True,
    deadline: float = math.inf,
) -> tuple[list[list[tuple[int, float]]], int]:
    """Adjacency lists of the k-nearest-neighbour graph (edges checked if ``check_edges``).

    Edges are not tried after ``deadline`` (a ``time.perf_counter()`` value [s]).

    Returns:
        ``(adjacency, edges_tried)``.
    """
    adjacency: list[list[tuple[int, float]]] = [[] for _ in range(nodes.shape[0])]
    pairs = _candidate_pairs(nodes, k, space)
    tried, _ = _connect_pairs(space, nodes, pairs, adjacency, check_edges, deadline)
    return adjacency, tried


def _connect_pairs(
    space: ConfigurationSpace,
    nodes: FloatArray,
    pairs: npt.NDArray[np.int64],
    adjacency: list[list[tuple[int, float]]],
    check_edges: bool,
    deadline: float,
) -> tuple[int, bool]:
    """Add the free ``pairs`` to ``adjacency``, the clock read before each edge check.

    Returns:
        ``(edges_tried, complete)``: ``complete`` is False when the deadline stopped it.
    """
    costs = space.distances(nodes[pairs[:, 1]], nodes[pairs[:, 0]])
    tried = 0
    for (i, j), c in zip(pairs.tolist(), costs.tolist()):
        if check_edges and time.perf_counter() > deadline:
            logger.debug("PRM: time limit after %d of %d edges", tried, pairs.shape[0])
            return tried, False
        tried += 1
        if check_edges and not space.motion_valid(nodes[i], nodes[j]):
            continue
        adjacency[i].append((j, c))
        adjacency[j].append((i, c))
    return tried, True


_FIRST_ROUND = 500
"""Samples of :func:`build_prm`'s first round; each later round doubles the roadmap."""
_SAMPLE_BATCH = 256
"""Candidates drawn per checker call (as :func:`~taskspace.planning.sample_free`)."""
_BYTES_PER_NODE = 256
"""Memory of a roadmap node beyond its coordinates [bytes] (lists, indices)."""
_BYTES_PER_NEIGHBOUR = 256
"""Memory of one candidate neighbour of a node [bytes] (two adjacency tuples, the pair)."""


def _physical_memory() -> int:
    """Bytes of RAM of the machine (``2**40`` when the system does not say)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return 1 << 40


def check_roadmap_memory(n: int, dim: int, k: int) -> None:
    """Refuse a roadmap of ``n`` nodes that cannot fit in the machine's memory.

    Called before anything is allocated when no time limit bounds the construction (with
    one, the rounds stop at the deadline and allocate what was sampled in time).

    Raises:
        InvalidInputError: the estimate (coordinates, ``k`` neighbours per node) exceeds the
            machine's physical memory.
    """
    need = n * (8 * dim + _BYTES_PER_NODE + _BYTES_PER_NEIGHBOUR * k)
    total = _physical_memory()
    if need > total:
        raise InvalidInputError(
            f"max_iterations={n}: a roadmap of {n} nodes with k_neighbors={k} needs about "
            f"{need / 2**30:.3g} GiB, more than this machine's {total / 2**30:.3g} GiB; give "
            "a smaller max_iterations or a time_limit_s (the roadmap then grows until it)"
        )


def _sample_round(
    space: ConfigurationSpace, n: int, rng: np.random.Generator, opts: PRMOptions, deadline: float
) -> tuple[FloatArray, bool]:
    """``n`` free samples drawn as :func:`~taskspace.planning.sample_free` draws them.

    Batches of 256 candidates, at most ``1000 n`` draws (fewer samples are returned then),
    the clock read before each batch when ``deadline`` is finite.

    Returns:
        ``(samples, late)``: ``late`` when the deadline passed before ``n`` were drawn.
    """
    out: list[FloatArray] = []
    have = draws = 0
    timed = not math.isinf(deadline)
    while have < n and draws < 1000 * max(n, 1):
        if timed and time.perf_counter() > deadline:
            return np.empty((0, space.dim)), True
        got = _candidates(space, opts.sampler, _SAMPLE_BATCH, opts.sigma, rng)
        draws += _SAMPLE_BATCH
        out.append(got)
        have += got.shape[0]
    if not out:
        return np.empty((0, space.dim)), False
    return np.vstack(out)[:n], False


def _new_pairs(
    space: ConfigurationSpace, nodes: FloatArray, first_new: int, k: int
) -> npt.NDArray[np.int64]:
    """Pairs (i, j), i < j, of every new node (index >= ``first_new``) and its k nearest."""
    if first_new == 0:
        return _candidate_pairs(nodes, k, space)
    n = nodes.shape[0]
    kk = min(k + 1, n)
    fresh = nodes[first_new:]
    if space.is_euclidean:
        _, idx = cKDTree(nodes).query(fresh, k=kk)
    else:
        idx = np.array([_nearest(space, nodes, q, kk)[1] for q in fresh])
    idx = np.asarray(idx, dtype=np.int64).reshape(fresh.shape[0], kk)
    rows = np.repeat(np.arange(first_new, n), kk)
    pairs = np.stack([rows, idx.ravel()], axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]  # the node itself
    return np.unique(np.sort(pairs, axis=1), axis=0)


def build_prm(
    space: ConfigurationSpace,
    options: PRMOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> Roadmap:
    """Build a probabilistic roadmap (slide 3:31).

    Without a time limit: ``n`` free samples, each connected to its ``k`` nearest (slide
    3:31); a size whose roadmap cannot fit in memory is refused before anything is
    allocated. With a time limit, in rounds: the first draws ``min(n, 500)`` free samples and
    connects them so, each later round doubles the roadmap, every new node connected to its
    ``k`` nearest among all nodes; the clock is read before every batch of 256 candidates and
    every edge check: a round whose sampling the deadline cuts is dropped, a round whose
    edges it cuts keeps the edges tried (:attr:`Roadmap.timed_out`).

    Args:
        space: configuration space with checker and straight-line local planner.
        options: settings (``n = max_iterations``, ``k``, sampler, ``time_limit_s``).
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Raises:
        InvalidInputError: invalid options, or a roadmap too large for memory (no time limit).
    """
    opts = options or PRMOptions()
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    t0 = time.perf_counter()
    return _build(space, opts, rng, t0 + check_time_limit(opts.time_limit_s), t0)


def _build(
    space: ConfigurationSpace,
    opts: PRMOptions,
    rng: np.random.Generator,
    deadline: float,
    t0: float,
) -> Roadmap:
    """:func:`build_prm` with a deadline (``time.perf_counter()`` value [s])."""
    n_samples = opts.roadmap_size()
    k = check_count(opts.k_neighbors, "k_neighbors", minimum=1)
    sample_free(space, 0, rng, strategy=opts.sampler, sigma=opts.sigma)  # validates, draws none
    if math.isinf(deadline):
        check_roadmap_memory(n_samples, space.dim, k)
    checks0 = space.checks
    version = space.world_version
    model_version = space.model_version
    nodes: FloatArray = np.empty((0, space.dim))
    adjacency: list[list[tuple[int, float]]] = []
    tried = 0
    timed_out = False
    # without a time limit, one round: slide 3:31's k-NN graph of all the nodes (rounds
    # try about 20 % more edges for the same nodes: their first nodes' neighbours are far)
    first = n_samples if math.isinf(deadline) else _FIRST_ROUND
    while nodes.shape[0] < n_samples:
        have = nodes.shape[0]
        want = min(n_samples, max(first, 2 * have)) - have
        fresh, late = _sample_round(space, want, rng, opts, deadline)
        if late:
            timed_out = True
            break
        if fresh.shape[0] == 0:  # no free sample in 1000 * want draws
            break
        nodes = np.vstack([nodes, fresh]) if have else fresh
        adjacency.extend([] for _ in range(fresh.shape[0]))
        pairs = _new_pairs(space, nodes, have, k)
        done, complete = _connect_pairs(space, nodes, pairs, adjacency, True, deadline)
        tried += done
        if not complete:
            timed_out = True
            break
        if fresh.shape[0] < want:  # the draw limit was hit
            break
    roadmap = Roadmap(
        nodes=nodes,
        adjacency=adjacency,
        build_time_s=time.perf_counter() - t0,
        collision_checks=space.checks - checks0,
        edges_tried=tried,
        world_version=version,
        model_version=model_version,
        timed_out=timed_out,
    )
    logger.debug("PRM: %d nodes, %d edges", roadmap.size, roadmap.edges.shape[0])
    return roadmap


def _attach(
    space: ConfigurationSpace,
    roadmap: Roadmap,
    q: FloatArray,
    k: int,
    check_edges: bool,
    budget: Budget | None = None,
    avoid: Sequence[Segment] = (),
) -> tuple[list[tuple[int, float]], bool]:
    """Edges (node, cost) from ``q`` to its k nearest roadmap nodes that pass the local planner.

    With a ``budget`` the clock is read before each batch of each edge's checks; the
    segments of ``avoid`` are left out unchecked.

    Returns:
        ``(edges, late)``: ``late`` when the deadline stopped it (the edges checked free
        before are returned).
    """
    kk = min(k, roadmap.size)
    if kk == 0:
        return [], False
    if space.is_euclidean:
        dist, idx = roadmap.kdtree.query(q, k=kk)
    else:
        dist, idx = _nearest(space, roadmap.nodes, q, kk)
    out: list[tuple[int, float]] = []
    for d, j in zip(np.atleast_1d(dist).tolist(), np.atleast_1d(idx).tolist()):
        if avoid and _avoids(avoid, q, roadmap.nodes[j]):
            continue
        if check_edges:
            free = (
                space.motion_valid(q, roadmap.nodes[j])
                if budget is None
                else budget.motion_valid(space, q, roadmap.nodes[j])
            )
            if free is None:
                return out, True
            if not free:
                continue
        out.append((int(j), float(d)))
    return out, False


def query_graph(
    roadmap: Roadmap,
    start_edges: list[tuple[int, float]],
    goal_edges: list[list[tuple[int, float]]],
    goal_costs: list[float | None],
    q_goals: FloatArray,
    search: str,
    blocked: set[tuple[int, int]] | None = None,
    space: ConfigurationSpace | None = None,
) -> tuple[list[int], float]:
    """Shortest path from the start to the nearest of several goals over the roadmap.

    The start is node ``-1``, goal ``i`` node ``-2 - i`` (joined to the roadmap nodes of
    ``goal_edges[i]`` and to the start at cost ``goal_costs[i]`` unless ``None``); a search
    target one step past every goal (cost 0) picks the cheapest. Returns the node ids from
    ``-1`` to the goal reached and the cost; ``([], inf)`` if no goal is connected. A* takes
    the distance to the nearest goal in ``space``'s metric (Euclidean without one):
    admissible for edge costs ``d(q, q')`` of a metric.
    """
    s = -1
    k = len(goal_edges)
    target = -2 - k
    goal_in: dict[int, list[tuple[int, float]]] = {}
    for i, edges in enumerate(goal_edges):
        for j, c in edges:
            goal_in.setdefault(j, []).append((-2 - i, c))
    blocked = blocked or set()
    adjacency = roadmap.adjacency

    def free(node: int, edges: Iterable[tuple[int, float]]) -> list[tuple[int, float]]:
        return [e for e in edges if (min(node, e[0]), max(node, e[0])) not in blocked]

    def neighbors(node: int) -> Iterable[tuple[int, float]]:
        if node == s:
            direct = [(-2 - i, c) for i, c in enumerate(goal_costs) if c is not None]
            return free(s, list(start_edges) + direct)
        if node == target:
            return ()
        if node < 0:  # a goal: the search target is one step away
            return [(target, 0.0)]
        return free(node, adjacency[node] + goal_in.get(node, []))

    if search == "astar":
        nodes = roadmap.nodes

        def heuristic(node: int) -> float:
            if node < 0:
                return 0.0
            if space is None or space.is_euclidean:
                return float(np.min(np.linalg.norm(q_goals - nodes[node], axis=1)))
            return float(np.min(space.distances(q_goals, nodes[node])))

        res = astar(neighbors, s, target, heuristic)
    else:
        res = dijkstra(neighbors, s, target)
    if not res.success:
        return [], math.inf
    return [int(v) for v in res.path[:-1]], float(res.cost)


def _assemble(
    roadmap: Roadmap, ids: list[int], q_start: FloatArray, q_goals: FloatArray
) -> FloatArray:
    pts = [q_start if v == -1 else q_goals[-2 - v] if v < 0 else roadmap.nodes[v] for v in ids]
    return np.asarray(pts)


def prm_query(
    space: ConfigurationSpace,
    roadmap: Roadmap,
    start: Any,
    goal: Any,
    options: PRMOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Answer one query on a roadmap (slide 3:30); the roadmap is left unchanged.

    Args:
        space: the configuration space the roadmap was built in.
        roadmap: from :func:`build_prm`.
        start: ``q_start``.
        goal: ``q_goal`` (size d), several goal configurations (k, d), or a
            :class:`~taskspace.planning.GoalRegion` (see :mod:`taskspace.planning.goals`:
            its valid samples among 20 are the goal states; a start inside it is a
            one-point path). Each goal is joined to its k nearest roadmap nodes; the path
            ends at the goal of the shortest roadmap path.
        options: ``k_neighbors``, ``search`` and ``time_limit_s`` (the query's budget: the
            clock is read before each batch of each edge check) are used (and ``seed`` for a
            region).
        rng: random generator of a region's samples (default: from ``options.seed``).

    Returns:
        A :class:`PlannerResult` (``NO_PATH`` when start and goal are not connected,
        ``TIME_LIMIT`` when the deadline stopped the edge checks before a path was found);
        ``log["goal_states"]`` counts the goal configurations.

    Raises:
        PlanningError: start or goal outside the bounds or in collision; the roadmap was
            built for another version of the obstacle world.
        InvalidInputError: ``certify`` on a space without a robot.

    Certified paths: with ``options.certify`` the path is proven free between its checked
    points (:func:`~taskspace.planning.certify.certify_planned`, within ``time_limit_s``):
    ``log`` has ``certified``, ``min_distance`` [m] and ``certify_attempts``; an uncertified
    path is searched again without the segment that failed (``certify_retries`` times; the
    roadmap is left unchanged) and, if none can be certified, the result has
    ``success=False``, status ``UNCERTIFIED`` and the failing segment in ``log``.
    """
    opts = options or PRMOptions()
    limit = check_time_limit(opts.time_limit_s)
    avoid: list[Segment] = []
    tried: list[PlannerResult] = []

    def plan(attempt: int, left: float) -> PlannerResult:
        if tried:  # its log names the segment the certificate failed on
            avoid.extend(uncertified_segment(tried[-1]))
        t0 = time.perf_counter()
        tried.append(_query(space, roadmap, start, goal, opts, rng, t0 + left, t0, avoid))
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
    roadmap: Roadmap,
    start: Any,
    goal: Any,
    opts: PRMOptions,
    rng: np.random.Generator | None,
    deadline: float,
    t0: float,
    avoid: Sequence[Segment] = (),
) -> PlannerResult:
    """:func:`prm_query` with a deadline (``time.perf_counter()`` value [s]).

    The limit convention's order (:mod:`taskspace.planning.limits`): a start equal to a goal
    or inside the goal region first, then the clock, then the straight lines, then the
    roadmap. The segments of ``avoid`` (those whose certificate failed) are not used.
    """
    checks0, edges0 = space.checks, space.edge_checks
    check_roadmap_world(space, roadmap)
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    if region is not None:
        rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
        goals = region_samples(space, region, rng, REGION_FIRST_ATTEMPTS, deadline)
    q_goals = np.asarray(goals, dtype=np.float64).reshape(-1, space.dim)
    budget = Budget(MAX_INT64, math.inf, t0)
    budget.deadline = deadline
    ids: list[int] = []
    cost = math.inf
    late = False
    same = [i for i, g in enumerate(goals) if np.array_equal(g, q_start)]
    if region is not None and region.contains(q_start):
        ids, cost = [-1], 0.0
    elif same:
        ids, cost = [-1, -2 - same[0]], 0.0
    elif goals and budget.out_of_time():
        late = True
    elif goals:
        direct: list[float | None] = []
        for g in goals:  # the straight lines first (the limit convention)
            if avoid and _avoids(avoid, q_start, g):
                direct.append(None)
                continue
            free = budget.motion_valid(space, q_start, g)
            late = free is None
            if late:
                break
            direct.append(space.distance(q_start, g) if free else None)
        start_edges: list[tuple[int, float]] = []
        goal_edges: list[list[tuple[int, float]]] = []
        if not late:
            start_edges, late = _attach(
                space, roadmap, q_start, opts.k_neighbors, True, budget, avoid
            )
        for g in goals:
            if late:
                break
            edges, late = _attach(space, roadmap, g, opts.k_neighbors, True, budget, avoid)
            goal_edges.append(edges)
        if not late:
            blocked = avoided_pairs(roadmap.nodes, avoid) if avoid else None
            ids, cost = query_graph(
                roadmap,
                start_edges,
                goal_edges,
                direct,
                q_goals,
                opts.search,
                blocked=blocked,
                space=space,
            )
    success = bool(ids)
    path = _assemble(roadmap, ids, q_start, q_goals) if success else np.empty((0, space.dim))
    dt = time.perf_counter() - t0
    length = result_length(space, path, success)
    status = (
        PlannerStatus.SOLVED
        if success
        else PlannerStatus.TIME_LIMIT
        if late
        else PlannerStatus.NO_PATH
    )
    return PlannerResult(
        success=success,
        status=status,
        path=path,
        path_length=length,
        iterations=roadmap.size,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=dt,
        log={
            "graph_cost": cost,
            "roadmap_nodes": float(roadmap.size),
            "goal_states": float(len(goals)),
            **limit_log(status, length, dt),
        },
    )


def prm(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: PRMOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> tuple[PlannerResult, Roadmap]:
    """Build a roadmap and answer one query; ``time_s`` includes the construction.

    Threads: Python code (the GIL runs one thread at a time; Ctrl-C interrupts it). Plans in
    several threads give the results of sequential runs when each thread has its own space
    (checker) and ``rng``; a compiled checker shared by threads is locked, a space's counters
    and a Python checker are not.

    Args:
        space: configuration space with checker and straight-line local planner.
        start: ``q_start``.
        goal: one goal configuration, several (k, d) or a goal region (see
            :func:`prm_query`).
        options: settings; ``max_iterations`` is the roadmap's size (the cap),
            ``time_limit_s`` the budget of the construction and the query together.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        ``(result, roadmap)``; reuse the roadmap with :func:`prm_query`. Without a path the
        status is ``TIME_LIMIT`` when the deadline cut the construction or the query, else
        ``ITERATION_LIMIT`` (the
        roadmap of ``max_iterations`` samples does not connect start and goal). ``log`` has
        ``stopped_by`` and the cost (path length) over time (``costs``, ``cost_times``), as
        every planner (:mod:`taskspace.planning.limits`). With ``options.certify``, ``log``
        has ``certified``, ``min_distance`` [m] and ``certify_attempts``, and the roadmap is
        the last one built.

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: bad options; ``certify`` on a space without a robot.

    Certified paths: with ``options.certify`` the path is proven free between its checked
    points by :func:`~taskspace.planning.certify_path`; an uncertified path is re-planned
    with a new roadmap (seeds ``seed + 1``, ... or the next draws of ``rng``;
    ``certify_retries`` times, within ``time_limit_s``, which covers the certification)
    that does not use the segments whose certificate failed (the straight line, a start or
    goal edge would otherwise be passed and taken again) and, if none can be certified, the
    result has ``success=False``, status ``UNCERTIFIED`` and the failing segment in ``log``.
    """
    opts = options or PRMOptions()
    space.check_endpoint(start, "start")
    goal_states(space, goal)  # refuse a bad goal before building
    limit = check_time_limit(opts.time_limit_s)
    seed = check_seed(opts.seed)
    avoid: list[Segment] = []
    tried: list[PlannerResult] = []

    def plan(attempt: int, left: float) -> tuple[PlannerResult, Roadmap]:
        if tried:  # its log names the segment the certificate failed on
            avoid.extend(uncertified_segment(tried[-1]))
        generator = rng if rng is not None else np.random.default_rng(seed + attempt)
        result, roadmap = _prm(space, start, goal, opts, generator, left, avoid)
        tried.append(result)
        return result, roadmap

    return certify_keeping(space, plan, opts, time_limit_s=limit)


def _prm(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: PRMOptions,
    rng: np.random.Generator,
    time_limit: float,
    avoid: Sequence[Segment] = (),
) -> tuple[PlannerResult, Roadmap]:
    """:func:`prm` without certification, under ``time_limit`` [s], not using ``avoid``."""
    checks0, edges0 = space.checks, space.edge_checks
    t0 = time.perf_counter()
    deadline = t0 + time_limit
    roadmap = _build(space, opts, rng, deadline, t0)
    result = _query(space, roadmap, start, goal, opts, rng, deadline, t0, avoid)
    if not result.success and result.status is PlannerStatus.NO_PATH:
        # every sample drawn and edge tried: the roadmap of max_iterations samples does not
        # connect them (unless the deadline cut the construction)
        timed_out = roadmap.timed_out
        result.status = PlannerStatus.TIME_LIMIT if timed_out else PlannerStatus.ITERATION_LIMIT
    result.collision_checks = space.checks - checks0
    result.edge_checks = space.edge_checks - edges0
    result.log.update(limit_log(result.status, result.path_length, result.time_s))
    return result, roadmap
