"""Dijkstra and A* on generic weighted graphs (slide 3:26).

Dijkstra labels nodes incrementally with their cost-from-start ``g`` and always expands the
open node of smallest ``g``; it returns optimal paths for non-negative edge costs. A* expands
the node of smallest ``f = g + w h`` where ``h`` is a heuristic (cost-to-go estimate); with an
admissible ``h`` (never over-estimating) and ``w = 1`` it is also optimal, and it expands fewer
nodes.

The graph can be given as

* a callable ``neighbors(node) -> iterable of (neighbor, edge_cost)`` (any hashable nodes),
* an adjacency list ``adj[i] = [(j, cost), ...]`` over integer nodes ``0..n-1``,
* a scipy sparse matrix (CSR or convertible) whose entry ``(i, j)`` is the cost of edge
  ``i -> j`` (explicitly stored zeros are zero-cost edges).

Edge costs are non-negative numbers; ``+inf`` is an edge never taken; a negative or NaN cost,
a start or goal that is not a node of an adjacency list or matrix and a NaN heuristic value
are errors.

The same functions serve grid planners and roadmaps (PRM).

Thread safety: :class:`GraphSearchOptions` and :class:`SearchStatus` are immutable; the searches
keep their state local to the call (the graph callbacks are only called); a
:class:`GraphSearchResult` is plain result data, not locked: do not modify it while another thread
reads it.
"""

from __future__ import annotations

import enum
import heapq
import itertools
import logging
import math
import time
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace.errors import InvalidInputError, PlanningError, TaskspaceError

logger = logging.getLogger(__name__)

Neighbors = Callable[[Any], Iterable[tuple[Any, float]]]
Graph = Neighbors | Sequence[Sequence[tuple[int, float]]] | Any
Heuristic = Callable[[Any], float] | Sequence[float] | np.ndarray


class SearchStatus(enum.Enum):
    """Outcome of a graph search."""

    FOUND = "found"
    """A path to the goal was found."""
    EXHAUSTED = "exhausted"
    """No goal was given and every reachable node was labelled (single-source distances)."""
    UNREACHABLE = "unreachable"
    """The goal is not reachable from the start."""
    EXPANSION_LIMIT = "expansion_limit"
    """``max_expansions`` was reached before the goal."""


@dataclass(frozen=True, kw_only=True)
class GraphSearchOptions:
    """Settings of :func:`dijkstra` and :func:`astar`.

    Attributes:
        max_expansions: stop after this many node expansions (``None`` = unlimited).
        heuristic_weight: ``w`` in ``f = g + w h`` (A* only); ``w > 1`` gives weighted A*,
            faster but only ``w``-suboptimal.
    """

    max_expansions: int | None = None
    heuristic_weight: float = 1.0

    def __post_init__(self) -> None:
        _check_options(self)


def _check_options(options: GraphSearchOptions) -> None:
    """Refuse a negative or non-integer ``max_expansions`` and a bad ``heuristic_weight``."""
    cap = options.max_expansions
    if cap is not None and (
        isinstance(cap, bool) or not isinstance(cap, (int, np.integer)) or cap < 0
    ):
        raise InvalidInputError(f"max_expansions must be None or an integer >= 0, got {cap!r}")
    w = options.heuristic_weight
    if isinstance(w, bool) or not isinstance(w, (int, float, np.integer, np.floating)):
        raise InvalidInputError(f"heuristic_weight must be a number, got {w!r}")
    if not math.isfinite(w) or w < 0:
        raise InvalidInputError(f"heuristic_weight must be finite and >= 0, got {w}")


@dataclass
class GraphSearchResult:
    """Result of a graph search.

    Attributes:
        success: ``True`` if the goal was reached (or, without goal, the search completed).
        status: why the search stopped.
        path: nodes from start to goal (``[start]`` without goal; ``[]`` when not found).
        cost: path cost (``inf`` when not found).
        distances: cost-from-start ``g`` of every labelled node (final for closed nodes).
        parents: back-pointers of the search tree.
        expanded: number of nodes expanded (popped and closed).
        relaxed: number of edge relaxations that improved a label.
        time_s: wall-clock time [s].
    """

    success: bool
    status: SearchStatus
    path: list[Any]
    cost: float
    distances: dict[Any, float] = field(repr=False)
    parents: dict[Any, Any] = field(repr=False)
    expanded: int
    relaxed: int
    time_s: float


def as_neighbors(graph: Graph) -> Neighbors:
    """Turn a callable, an adjacency list or a sparse matrix into a neighbor function.

    Args:
        graph: see the module docstring.

    Returns:
        ``neighbors(node) -> iterable of (neighbor, cost)``.

    Raises:
        InvalidInputError: for unsupported graph types; (when called) for a node that is not
            in an adjacency list or sparse matrix.
    """
    return _graph(graph)[0]


def _graph(graph: Graph) -> tuple[Neighbors, int | None]:
    """:func:`as_neighbors` and the node count of integer-node graphs (``None``: a callable)."""
    if callable(graph):
        return graph, None
    if hasattr(graph, "tocsr"):
        csr = graph.tocsr()
        if csr.ndim != 2 or csr.shape[0] != csr.shape[1]:
            raise InvalidInputError(
                f"a sparse cost matrix must be square (n, n), got shape {csr.shape}"
            )
        indptr = csr.indptr.tolist()
        indices = csr.indices.tolist()
        data = np.asarray(csr.data, dtype=float).tolist()
        n = int(csr.shape[0])

        def csr_neighbors(i: int) -> Iterable[tuple[int, float]]:
            if not 0 <= i < n:
                raise InvalidInputError(f"node {i!r} is not a node of the graph (0..{n - 1})")
            a, b = indptr[i], indptr[i + 1]
            return zip(indices[a:b], data[a:b])

        return csr_neighbors, n
    if isinstance(graph, Sequence) and not isinstance(graph, (str, bytes)):
        adj = graph
        n = len(adj)

        def list_neighbors(i: int) -> Iterable[tuple[int, float]]:
            if not 0 <= i < n:  # an edge to a node the list does not have
                raise InvalidInputError(
                    f"node {i!r} is not a node of the adjacency list (0..{n - 1})"
                )
            return adj[i]

        return list_neighbors, n
    raise InvalidInputError(
        "graph must be a callable neighbors(node), an adjacency list or a scipy sparse "
        f"matrix, got {type(graph).__name__}"
    )


def _check_node(node: Any, n: int | None, name: str) -> None:
    """A start or goal of an integer-node graph: an integer in ``0..n-1``."""
    if n is None:
        return
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)) or not 0 <= node < n:
        raise InvalidInputError(
            f"{name} must be a node of the graph: an integer in 0..{n - 1}, got {node!r}"
        )


def _as_heuristic(heuristic: Heuristic | None, n: int | None) -> Callable[[Any], float]:
    if heuristic is None:
        return lambda _n: 0.0
    if callable(heuristic):
        return heuristic
    arr = np.asarray(heuristic, dtype=float)
    if arr.ndim != 1 or (n is not None and arr.size != n):
        size = "one value per node" if n is None else f"{n} values, one per node"
        raise InvalidInputError(f"a heuristic array must have {size}, got shape {arr.shape}")
    if np.isnan(arr).any():
        raise InvalidInputError(
            f"the heuristic is NaN at nodes {np.flatnonzero(np.isnan(arr))[:10].tolist()}"
        )
    values: list[float] = arr.tolist()
    count = len(values)

    def h(node: Any) -> float:
        if (
            isinstance(node, bool)
            or not isinstance(node, (int, np.integer))
            or not (0 <= node < count)
        ):
            raise InvalidInputError(
                f"the heuristic array has {count} values; node {node!r} has none"
            )
        return values[node]

    return h


def _reconstruct(parents: dict[Any, Any], start: Any, goal: Any) -> list[Any]:
    path = [goal]
    while path[-1] != start:
        path.append(parents[path[-1]])
    path.reverse()
    return path


def _search(
    graph: Graph,
    start: Hashable,
    goal: Hashable | None,
    heuristic: Heuristic | None,
    options: GraphSearchOptions,
) -> GraphSearchResult:
    t0 = time.perf_counter()
    _check_options(options)  # (also here: a frozen options object can be changed behind it)
    neighbors, n = _graph(graph)
    _check_node(start, n, "start")
    if goal is not None:
        _check_node(goal, n, "goal")
    h = _as_heuristic(heuristic, n)
    w = float(options.heuristic_weight)
    limit = options.max_expansions if options.max_expansions is not None else math.inf
    g: dict[Any, float] = {start: 0.0}
    parents: dict[Any, Any] = {}
    closed: set[Any] = set()
    counter = itertools.count()
    h0 = w * h(start) if goal is not None else 0.0
    if h0 != h0:
        raise InvalidInputError(f"the heuristic is NaN at the start node {start!r}")
    # Ties on f are broken towards smaller h (deeper nodes), then FIFO.
    heap: list[tuple[float, float, int, Any]] = [(h0, h0, next(counter), start)]
    expanded = relaxed = 0
    status = SearchStatus.EXHAUSTED if goal is None else SearchStatus.UNREACHABLE
    use_h = goal is not None and heuristic is not None
    push, pop = heapq.heappush, heapq.heappop
    while heap:
        _, _, _, node = pop(heap)
        if node in closed:
            continue
        if node == goal:
            status = SearchStatus.FOUND
            break
        if expanded >= limit:
            status = SearchStatus.EXPANSION_LIMIT
            break
        closed.add(node)
        expanded += 1
        g_node = g[node]
        try:
            for nb, cost in neighbors(node):
                if not cost >= 0:  # negative or NaN (+inf: an edge never taken)
                    kind = "negative" if cost < 0 else "NaN"
                    raise InvalidInputError(
                        f"edge {node!r} -> {nb!r} has {kind} cost {cost}; Dijkstra and A* "
                        "need non-negative edge costs"
                    )
                if nb in closed:
                    continue
                g_new = g_node + cost
                if g_new == math.inf and cost != math.inf:
                    raise InvalidInputError(
                        f"the path cost to node {nb!r} overflows (g = {g_node} plus an edge of "
                        f"{cost}); scale the edge costs down"
                    )
                if g_new < g.get(nb, math.inf):
                    g[nb] = g_new
                    parents[nb] = node
                    relaxed += 1
                    hn = w * h(nb) if use_h else 0.0
                    if hn != hn:
                        raise InvalidInputError(f"the heuristic is NaN at node {nb!r}")
                    push(heap, (g_new + hn, hn, next(counter), nb))
        except TaskspaceError:
            raise
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"neighbors({node!r}) failed or gave an item that is not a (neighbor, cost) "
                f"pair with a numeric cost: {exc}"
            ) from exc
    if status is SearchStatus.FOUND:
        path = _reconstruct(parents, start, goal)
        cost_out = g[goal]
    elif status is SearchStatus.EXHAUSTED:
        path, cost_out = [start], 0.0
    else:
        path, cost_out = [], math.inf
    success = status in (SearchStatus.FOUND, SearchStatus.EXHAUSTED)
    dt = time.perf_counter() - t0
    logger.debug("graph search %s: %d expanded in %.3f s", status.value, expanded, dt)
    return GraphSearchResult(
        success=success,
        status=status,
        path=path,
        cost=cost_out,
        distances=g,
        parents=parents,
        expanded=expanded,
        relaxed=relaxed,
        time_s=dt,
    )


def dijkstra(
    graph: Graph,
    start: Hashable,
    goal: Hashable | None = None,
    *,
    options: GraphSearchOptions | None = None,
) -> GraphSearchResult:
    """Dijkstra's algorithm (slide 3:26): optimal paths for non-negative edge costs.

    Repeatedly closes the open node ``n`` of least ``g(n)`` and relaxes
    ``g(m) <- min(g(m), g(n) + c(n, m))`` for its neighbors ``m``.

    Args:
        graph: neighbor callable, adjacency list or sparse cost matrix.
        start: start node.
        goal: goal node, or ``None`` to label every reachable node.
        options: search settings.

    Returns:
        A :class:`GraphSearchResult`; ``distances`` holds ``g`` of the labelled nodes.

    Raises:
        InvalidInputError: if an edge with negative cost is met.
    """
    return _search(graph, start, goal, None, options or GraphSearchOptions())


def astar(
    graph: Graph,
    start: Hashable,
    goal: Hashable,
    heuristic: Heuristic,
    *,
    options: GraphSearchOptions | None = None,
) -> GraphSearchResult:
    """A* search: Dijkstra ordered by ``f(n) = g(n) + w h(n)``.

    Args:
        graph: neighbor callable, adjacency list or sparse cost matrix.
        start: start node.
        goal: goal node.
        heuristic: ``h(node)`` callable or a per-node array (integer nodes); admissible
            (``h <= true cost-to-go``) for optimal paths.
        options: search settings (``heuristic_weight``, ``max_expansions``).

    Returns:
        A :class:`GraphSearchResult`.

    Raises:
        PlanningError: if ``goal`` is ``None``.
        InvalidInputError: if an edge with negative cost is met.
    """
    if goal is None:
        raise PlanningError("astar needs a goal node; use dijkstra for single-source distances")
    return _search(graph, start, goal, heuristic, options or GraphSearchOptions())
