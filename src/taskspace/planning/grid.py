"""Occupancy grids, the wavefront planner (slides 3:18-3:25) and Dijkstra / A* on grids.

Cells are addressed ``(row, col)``; the cell ``(i, j)`` covers the world square
``[x0 + j h, x0 + (j + 1) h) x [y0 + i h, y0 + (i + 1) h)`` with resolution ``h`` [m/cell].

Wavefront (slide 3:19): label obstacles 1 and the goal 2, then repeatedly give every
still-zero free neighbour of the cells labelled ``k`` the label ``k + 1`` (4- or
8-connectivity) until no zero is adjacent to a labelled cell; zeros remain only in unreachable
regions (slide 3:24). A shortest path (in number of moves) follows strictly decreasing labels
from the start to the goal (slide 3:25).

Dijkstra / A* use edge costs 1 (orthogonal) and ``sqrt(2)`` (diagonal), in cells.

Thread safety: :class:`OccupancyGrid` is an immutable value (do not modify its ``occupied`` array
in place), :class:`GridSearchOptions` and :class:`GridStatus` are immutable; the searches keep
their state local to the call; :class:`GridPathResult` and :class:`WavefrontResult` are plain
result data, not locked: do not modify them while another thread reads them.
"""

from __future__ import annotations

import enum
import logging
import math
import operator
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_vector, check_positive
from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.graph_search import (
    GraphSearchOptions,
    SearchStatus,
    astar,
    dijkstra,
)

logger = logging.getLogger(__name__)

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]

_OFFSETS4 = ((-1, 0), (1, 0), (0, -1), (0, 1))
_OFFSETS8 = (*_OFFSETS4, (-1, -1), (-1, 1), (1, -1), (1, 1))

#: Wavefront label of obstacle cells (slide 3:19).
OBSTACLE = 1
#: Wavefront label of the goal cell (slide 3:19).
GOAL = 2


def _offsets(connectivity: int) -> tuple[tuple[int, int], ...]:
    if connectivity == 4:
        return _OFFSETS4
    if connectivity == 8:
        return _OFFSETS8
    raise InvalidInputError(f"connectivity must be 4 or 8, got {connectivity!r}")


@dataclass(frozen=True)
class OccupancyGrid:
    """A 2-D occupancy grid.

    Attributes:
        occupied: boolean array ``(rows, cols)``, ``True`` for obstacle cells (numbers 0 and
            1 are taken as booleans; other values are refused: threshold them first).
        resolution: cell size ``h`` [m].
        origin: world coordinates ``(x0, y0)`` of the corner of cell ``(0, 0)`` [m].
    """

    occupied: npt.NDArray[np.bool_]
    resolution: float = 1.0
    origin: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        occ = np.asarray(self.occupied)
        if occ.ndim != 2 or occ.size == 0:
            raise InvalidInputError(
                f"occupied must be a non-empty 2-D array, got shape {occ.shape}"
            )
        if occ.dtype.kind == "f" and np.isnan(occ).any():
            raise InvalidInputError(
                "occupied has NaN entries (NaN is neither free nor occupied) at cells "
                f"{np.argwhere(np.isnan(occ))[:5].tolist()}"
            )
        if occ.dtype != np.bool_:
            if occ.dtype.kind not in "iuf":
                raise InvalidInputError(
                    f"occupied must be booleans (True = obstacle) or 0/1, got dtype {occ.dtype}"
                )
            other = (occ != 0) & (occ != 1)
            if other.any():
                # (0.3 or 255 was an obstacle: an occupancy probability or an image read as
                # "non-zero = occupied", where a threshold or black = obstacle was meant)
                raise InvalidInputError(
                    "occupied must be booleans (True = obstacle) or 0/1, got values such as "
                    f"{np.unique(occ[other])[:5].tolist()} at cells "
                    f"{np.argwhere(other)[:3].tolist()}; threshold it yourself, e.g. "
                    "OccupancyGrid(probabilities > 0.5) or OccupancyGrid(image == 0)"
                )
        object.__setattr__(self, "occupied", occ.astype(bool))
        check_positive(self.resolution, "resolution")
        origin = as_vector(self.origin, 2, "origin")
        object.__setattr__(self, "origin", (float(origin[0]), float(origin[1])))

    @property
    def shape(self) -> tuple[int, int]:
        """Grid shape ``(rows, cols)``."""
        return (int(self.occupied.shape[0]), int(self.occupied.shape[1]))

    def in_bounds(self, cell: Any) -> bool:
        """Whether ``cell = (row, col)`` (two integers) lies inside the grid."""
        r, c = _cell(cell, "cell")
        return 0 <= r < self.shape[0] and 0 <= c < self.shape[1]

    def cell_of(self, point: Any) -> tuple[int, int]:
        """Cell ``(row, col)`` containing the world point ``(x, y)`` [m] (may be out of bounds)."""
        p = as_vector(point, 2, "point")
        col = math.floor((p[0] - self.origin[0]) / self.resolution)
        row = math.floor((p[1] - self.origin[1]) / self.resolution)
        return (row, col)

    def center_of(self, cells: Any) -> FloatArray:
        """World coordinates [m] of cell centres; ``cells`` is ``(2,)`` or ``(N, 2)``."""
        rc = np.asarray(cells, dtype=float)
        x = self.origin[0] + (rc[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (rc[..., 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def check_free_cell(self, cell: Any, name: str) -> tuple[int, int]:
        """Validate that ``cell`` is an in-bounds free cell; return it as ``(row, col)``.

        Raises:
            PlanningError: if the cell is outside the grid or occupied.
        """
        r, c = _cell(cell, name)
        if not self.in_bounds((r, c)):
            raise PlanningError(
                f"{name} cell ({r}, {c}) is outside the grid of shape {self.shape} "
                f"(rows 0..{self.shape[0] - 1}, cols 0..{self.shape[1] - 1})"
            )
        if self.occupied[r, c]:
            raise PlanningError(f"{name} cell ({r}, {c}) is inside an obstacle")
        return (r, c)


def _cell(cell: Any, name: str) -> tuple[int, int]:
    """``(row, col)`` of two integers (integral floats too: 3.0, not 3.5 nor NaN)."""
    try:
        if any(isinstance(v, (bool, np.bool_)) for v in cell):
            raise TypeError("a bool is not a cell index")
        r, c = (operator.index(v) if not isinstance(v, (float, np.floating)) else v for v in cell)
        if r != int(r) or c != int(c):
            raise ValueError
        return (int(r), int(c))
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(
            f"{name} must be a (row, col) pair of integers, got {cell!r}"
        ) from exc


class GridStatus(enum.Enum):
    """Outcome of a grid planner."""

    FOUND = "found"
    UNREACHABLE = "unreachable"
    EXPANSION_LIMIT = "expansion_limit"


@dataclass
class WavefrontResult:
    """Labels of the wavefront planner.

    Attributes:
        values: slide-3:19 labels: obstacles 1, goal 2, a free cell reached after ``k``
            moves ``2 + k``, unreachable free cells 0.
        distance: moves to the goal, ``-1`` for obstacles and unreachable cells.
        goal: goal cell.
        connectivity: 4 or 8.
        waves: number of wave iterations.
        time_s: wall-clock time [s].
    """

    values: IntArray
    distance: IntArray
    goal: tuple[int, int]
    connectivity: int
    waves: int
    time_s: float


@dataclass
class GridPathResult:
    """A path on a grid.

    Attributes:
        success: whether the goal was reached.
        status: why the planner stopped.
        path: cells ``(N, 2)`` from start to goal (``(0, 2)`` when not found).
        cost: path cost in cells (``inf`` when not found); multiply by the resolution for [m].
        expanded: cells expanded by the search (0 for wavefront descent).
        time_s: wall-clock time [s].
    """

    success: bool
    status: GridStatus
    path: IntArray
    cost: float
    expanded: int
    time_s: float


def wavefront(
    grid: OccupancyGrid, goal: Any, *, connectivity: Literal[4, 8] = 8
) -> WavefrontResult:
    """Wavefront labelling from ``goal`` (slides 3:19-3:24), one vectorised step per wave.

    Args:
        grid: the occupancy grid.
        goal: goal cell ``(row, col)``.
        connectivity: 4- or 8-point connectivity.

    Returns:
        A :class:`WavefrontResult`.

    Raises:
        PlanningError: if the goal is outside the grid or occupied.
    """
    t0 = time.perf_counter()
    offsets = _offsets(connectivity)
    g = grid.check_free_cell(goal, "goal")
    rows, cols = grid.shape
    # Pad with an obstacle border so that flat-index neighbours never leave the grid.
    pw = cols + 2
    free = np.zeros((rows + 2, cols + 2), dtype=bool)
    free[1:-1, 1:-1] = ~grid.occupied
    free_flat = free.ravel()
    dist = np.full(free_flat.shape, -1, dtype=np.int64)
    flat_off = np.array([dr * pw + dc for dr, dc in offsets], dtype=np.int64)
    start = (g[0] + 1) * pw + (g[1] + 1)
    dist[start] = 0
    frontier = np.array([start], dtype=np.int64)
    waves = 0
    while frontier.size:
        cand = (frontier[:, None] + flat_off[None, :]).ravel()
        cand = cand[free_flat[cand] & (dist[cand] < 0)]
        cand = np.unique(cand)
        waves += 1
        dist[cand] = waves
        frontier = cand
    dist2 = dist.reshape(rows + 2, cols + 2)[1:-1, 1:-1].copy()
    values = np.where(grid.occupied, OBSTACLE, np.where(dist2 >= 0, dist2 + GOAL, 0))
    return WavefrontResult(
        values=values.astype(np.int64),
        distance=dist2,
        goal=g,
        connectivity=connectivity,
        waves=waves - 1,
        time_s=time.perf_counter() - t0,
    )


def wavefront_path(result: WavefrontResult, start: Any) -> GridPathResult:
    """Descend the wavefront labels from ``start`` to the goal (slide 3:25).

    At each step move to the neighbour with the smallest label ``>= 2`` (neighbours are
    scanned in the order up, down, left, right, then diagonals; the first minimum wins).

    Args:
        result: labels from :func:`wavefront`.
        start: start cell ``(row, col)``.

    Returns:
        A :class:`GridPathResult`; ``cost`` is the number of moves.

    Raises:
        PlanningError: if the start is outside the grid or occupied.
    """
    t0 = time.perf_counter()
    values = result.values
    rows, cols = values.shape
    occ = values == OBSTACLE
    s = OccupancyGrid(occ).check_free_cell(start, "start")
    offsets = _offsets(result.connectivity)
    if result.distance[s] < 0:
        return GridPathResult(
            False, GridStatus.UNREACHABLE, np.zeros((0, 2), np.int64), math.inf, 0, 0.0
        )
    path = [s]
    r, c = s
    while values[r, c] != GOAL:
        best = None
        best_v = values[r, c]
        for dr, dc in offsets:
            rr, cc = r + dr, c + dc
            if 0 <= rr < rows and 0 <= cc < cols and GOAL <= values[rr, cc] < best_v:
                best, best_v = (rr, cc), values[rr, cc]
        if best is None:  # cannot happen for consistent labels
            raise PlanningError(f"wavefront labels are inconsistent at cell ({r}, {c})")
        r, c = best
        path.append(best)
    return GridPathResult(
        success=True,
        status=GridStatus.FOUND,
        path=np.asarray(path, dtype=np.int64),
        cost=float(len(path) - 1),
        expanded=0,
        time_s=time.perf_counter() - t0,
    )


@dataclass(frozen=True, kw_only=True)
class GridSearchOptions:
    """Settings of :func:`grid_search`.

    Attributes:
        connectivity: 4 or 8 neighbours.
        corner_cutting: allow a diagonal move past occupied orthogonal cells (``False``: a
            diagonal move needs both orthogonal cells it passes between free).
        heuristic_weight: A* weight ``w`` (1 = optimal).
        max_expansions: stop after this many expansions (``None`` = unlimited).
    """

    connectivity: Literal[4, 8] = 8
    corner_cutting: bool = False
    heuristic_weight: float = 1.0
    max_expansions: int | None = None


def grid_neighbors(
    grid: OccupancyGrid, connectivity: int = 8, corner_cutting: bool = False
) -> tuple[Any, int]:
    """Neighbour function over padded flat cell indices, for :mod:`graph_search`.

    Args:
        grid: the occupancy grid.
        connectivity: 4 or 8.
        corner_cutting: allow diagonal moves past occupied orthogonal cells (``False``:
            both orthogonal cells a diagonal move passes between must be free).

    Returns:
        ``(neighbors, padded_width)``: ``neighbors(k)`` yields ``(k', cost)`` with costs
        1 and ``sqrt(2)``; cell ``(r, c)`` has index ``(r + 1) * padded_width + c + 1``.
    """
    offsets = _offsets(connectivity)
    rows, cols = grid.shape
    pw = cols + 2
    free = np.zeros((rows + 2, cols + 2), dtype=bool)
    free[1:-1, 1:-1] = ~grid.occupied
    free_l = free.ravel().tolist()
    moves = []
    for dr, dc in offsets:
        cost = math.sqrt(2.0) if dr and dc else 1.0
        # orthogonal cells a diagonal move passes between
        side = (dr * pw, dc) if dr and dc else None
        moves.append((dr * pw + dc, cost, side))

    def neighbors(k: int) -> Iterable[tuple[int, float]]:
        out = []
        for off, cost, side in moves:
            n = k + off
            if not free_l[n]:
                continue
            if side is not None and not corner_cutting:
                if not (free_l[k + side[0]] and free_l[k + side[1]]):
                    continue
            out.append((n, cost))
        return out

    return neighbors, pw


def grid_search(
    grid: OccupancyGrid,
    start: Any,
    goal: Any,
    *,
    method: Literal["astar", "dijkstra"] = "astar",
    options: GridSearchOptions | None = None,
) -> GridPathResult:
    """Shortest grid path by A* (octile / Manhattan heuristic) or Dijkstra (slide 3:26).

    The A* heuristic is the exact obstacle-free cost: octile distance
    ``max(dr, dc) + (sqrt(2) - 1) min(dr, dc)`` for 8-connectivity, Manhattan ``dr + dc``
    for 4-connectivity; both are admissible and consistent, so A* returns optimal paths.

    Args:
        grid: the occupancy grid.
        start: start cell ``(row, col)``.
        goal: goal cell ``(row, col)``.
        method: ``"astar"`` or ``"dijkstra"``.
        options: search settings.

    Returns:
        A :class:`GridPathResult` with the cell path and its cost in cells.

    Raises:
        PlanningError: if start or goal is outside the grid or occupied.
        UnknownNameError: for an unknown method.
    """
    opts = options or GridSearchOptions()
    t0 = time.perf_counter()
    if method not in ("astar", "dijkstra"):
        raise UnknownNameError("method", str(method), ["astar", "dijkstra"])
    _offsets(opts.connectivity)
    s = grid.check_free_cell(start, "start")
    g = grid.check_free_cell(goal, "goal")
    neighbors, pw = grid_neighbors(grid, opts.connectivity, opts.corner_cutting)
    ks = (s[0] + 1) * pw + s[1] + 1
    kg = (g[0] + 1) * pw + g[1] + 1
    gopts = GraphSearchOptions(
        max_expansions=opts.max_expansions, heuristic_weight=opts.heuristic_weight
    )
    gr, gc = g[0] + 1, g[1] + 1
    if opts.connectivity == 8:
        d2 = math.sqrt(2.0) - 1.0

        def h(k: int) -> float:
            dr = abs(k // pw - gr)
            dc = abs(k % pw - gc)
            return float(max(dr, dc) + d2 * min(dr, dc))

    else:

        def h(k: int) -> float:
            return float(abs(k // pw - gr) + abs(k % pw - gc))

    if method == "astar":
        res = astar(neighbors, ks, kg, h, options=gopts)
    else:
        res = dijkstra(neighbors, ks, kg, options=gopts)
    if res.status is SearchStatus.FOUND:
        cells = np.array([(k // pw - 1, k % pw - 1) for k in res.path], dtype=np.int64)
        status = GridStatus.FOUND
    else:
        cells = np.zeros((0, 2), dtype=np.int64)
        status = (
            GridStatus.EXPANSION_LIMIT
            if res.status is SearchStatus.EXPANSION_LIMIT
            else GridStatus.UNREACHABLE
        )
    return GridPathResult(
        success=status is GridStatus.FOUND,
        status=status,
        path=cells,
        cost=res.cost,
        expanded=res.expanded,
        time_s=time.perf_counter() - t0,
    )
