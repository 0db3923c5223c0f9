"""Lazy PRM (Bohlin and Kavraki, ICRA 2000; slide 3:36: "not necessary for Lazy PRMs").

The roadmap is built *without* checking edges (nodes are still free samples). A query then
repeats::

    path <- shortest path in G from q_start to q_goal (Dijkstra / A*)
    check the edges of path with the local planner (results are cached)
    if all are free: return path
    else: remove the first colliding edge from G

until a free path is found or start and goal are disconnected. Only edges on candidate
shortest paths are ever checked, which saves most of the edge checks of a PRM.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace.errors import InvalidInputError
from taskspace.planning.configuration_space import ConfigurationSpace, path_length
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.prm import PRMOptions, Roadmap, _assemble, connect_roadmap, query_graph
from taskspace.planning.sampling import sample_free

logger = logging.getLogger(__name__)


@dataclass
class LazyRoadmap:
    """A roadmap whose edges are checked on demand.

    Attributes:
        roadmap: nodes and unchecked k-nearest-neighbour edges.
        valid: cache of edge checks ``(i, j) -> free`` (``i < j``), shared by queries.
    """

    roadmap: Roadmap
    valid: dict[tuple[int, int], bool] = field(default_factory=dict)


def build_lazy_prm(
    space: ConfigurationSpace,
    options: PRMOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> LazyRoadmap:
    """Sample free nodes and connect k nearest neighbours without checking the edges."""
    opts = options or PRMOptions()
    if opts.n_samples < 1 or opts.k_neighbors < 1:
        raise InvalidInputError("n_samples and k_neighbors must be >= 1")
    rng = rng if rng is not None else np.random.default_rng(opts.seed)
    t0 = time.perf_counter()
    checks0 = space.checks
    nodes = sample_free(space, opts.n_samples, rng, strategy=opts.sampler, sigma=opts.sigma)
    adjacency, _tried = connect_roadmap(space, nodes, opts.k_neighbors, check_edges=False)
    roadmap = Roadmap(
        nodes=nodes,
        adjacency=adjacency,
        build_time_s=time.perf_counter() - t0,
        collision_checks=space.checks - checks0,
        edges_tried=0,
    )
    return LazyRoadmap(roadmap=roadmap)


def lazy_prm_query(
    space: ConfigurationSpace,
    lazy: LazyRoadmap,
    start: Any,
    goal: Any,
    options: PRMOptions | None = None,
    *,
    time_limit_s: float | None = None,
) -> PlannerResult:
    """Answer a query on a lazy roadmap, checking only edges of candidate shortest paths.

    Args:
        space: the configuration space of the roadmap.
        lazy: from :func:`build_lazy_prm` (its edge cache grows).
        start: ``q_start``.
        goal: ``q_goal``.
        options: ``k_neighbors`` and ``search`` are used.
        time_limit_s: wall-clock budget [s].

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
    """
    opts = options or PRMOptions()
    t0 = time.perf_counter()
    deadline = math.inf if time_limit_s is None else t0 + time_limit_s
    checks0, edges0 = space.checks, space.edge_checks
    q_start = space.check_endpoint(start, "start")
    q_goal = space.check_endpoint(goal, "goal")
    roadmap = lazy.roadmap
    kk = min(opts.k_neighbors, roadmap.size)

    def near(q: Any) -> list[tuple[int, float]]:
        dist, idx = roadmap.kdtree.query(q, k=kk)
        return list(zip(np.atleast_1d(idx).tolist(), np.atleast_1d(dist).tolist()))

    start_edges, goal_edges = near(q_start), near(q_goal)
    direct = float(np.linalg.norm(q_goal - q_start))
    blocked: set[tuple[int, int]] = {k for k, ok in lazy.valid.items() if not ok}
    status = PlannerStatus.NO_PATH
    ids: list[int] = []
    rounds = 0
    points = {-1: q_start, -2: q_goal}

    def point(v: int) -> Any:
        return points[v] if v < 0 else roadmap.nodes[v]

    while True:
        if time.perf_counter() > deadline:
            status = PlannerStatus.TIME_LIMIT
            break
        rounds += 1
        ids, _ = query_graph(roadmap, start_edges, goal_edges, direct, q_goal, opts.search, blocked)
        if not ids:
            status = PlannerStatus.NO_PATH
            break
        bad = None
        for a, b in zip(ids[:-1], ids[1:]):  # noqa: RUF007
            key = (min(a, b), max(a, b))
            ok = lazy.valid.get(key) if a >= 0 and b >= 0 else None
            if ok is None:
                ok = space.motion_valid(point(a), point(b))
                if a >= 0 and b >= 0:
                    lazy.valid[key] = ok
            if not ok:
                bad = key
                break
        if bad is None:
            status = PlannerStatus.SOLVED
            break
        blocked.add(bad)
    # Edges already known to be invalid are removed in later queries as well.
    success = status is PlannerStatus.SOLVED
    path = _assemble(roadmap, ids, q_start, q_goal) if success else np.empty((0, space.dim))
    return PlannerResult(
        success=success,
        status=status,
        path=path,
        path_length=path_length(path) if success else math.inf,
        iterations=rounds,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=time.perf_counter() - t0,
        log={"search_rounds": float(rounds), "roadmap_nodes": float(roadmap.size)},
    )
