"""Graph and grid searches refuse what has no answer instead of answering wrongly.

Before: a NaN edge cost made the goal "unreachable" (the edge was silently dropped), a start
outside an adjacency list or sparse matrix was "unreachable", a grid cell (4.7, 4.2) was the
cell (4, 4), a NaN heuristic gave whatever order the heap made of it, a negative or fractional
``max_expansions`` stopped at once with EXPANSION_LIMIT, costs whose sum overflows made a
reachable goal "unreachable", and malformed neighbours raised bare TypeErrors or IndexErrors.
The valid answers are checked against scipy's shortest paths (an independent reference).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import shortest_path

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.planning.graph_search import GraphSearchOptions, astar, dijkstra
from taskspace.planning.grid import GridSearchOptions, OccupancyGrid, grid_search, wavefront

ADJ = [[(1, 1.0), (2, 5.0)], [(2, 1.0)], []]
NAN = float("nan")


def _grid() -> OccupancyGrid:
    occ = np.zeros((5, 5), bool)
    occ[2, 1:4] = True
    return OccupancyGrid(occ)


@pytest.mark.parametrize(
    "adj",
    [
        [[(1, 1.0)], [(2, NAN)], []],  # NaN edge: was UNREACHABLE
        [[(1, -1.0)], [(2, 1.0)], []],
        [[(1, 1.0)], [(2, "a")], []],  # not a number
        [[1], []],  # not a (neighbor, cost) pair
        [[(5, 1.0)], [], []],  # an edge to a node the list does not have
    ],
)
def test_malformed_edges_are_errors(adj: list) -> None:
    with pytest.raises(InvalidInputError):
        dijkstra(adj, 0, len(adj) - 1)


def test_infinite_edge_is_never_taken() -> None:
    res = dijkstra([[(1, 1.0)], [(2, math.inf)], []], 0, 2)
    assert not res.success and res.cost == math.inf


def test_overflowing_path_cost_is_an_error() -> None:
    with pytest.raises(InvalidInputError, match="overflows"):
        dijkstra([[(1, 1e308)], [(2, 1e308)], []], 0, 2)


@pytest.mark.parametrize("node", [7, -1, 1.0, True, "0"])
@pytest.mark.parametrize("which", ["start", "goal"])
def test_nodes_outside_the_graph_are_errors(node: object, which: str) -> None:
    matrix = sp.csr_matrix(np.array([[0, 1.0, 0], [0, 0, 2.0], [0, 0, 0]]))
    for graph in (ADJ, matrix):
        args = (node, 2) if which == "start" else (0, node)
        with pytest.raises(InvalidInputError, match=which):
            dijkstra(graph, *args)


def test_heuristics_nan_and_wrong_size_are_errors() -> None:
    with pytest.raises(InvalidInputError, match="NaN"):
        astar(ADJ, 0, 2, lambda n: NAN)
    with pytest.raises(InvalidInputError, match="NaN"):
        astar(ADJ, 0, 2, lambda n: 0.0 if n == 0 else NAN)
    with pytest.raises(InvalidInputError, match="3 values"):
        astar(ADJ, 0, 2, np.zeros(1))
    with pytest.raises(InvalidInputError, match="NaN"):
        astar(ADJ, 0, 2, np.array([0.0, NAN, 0.0]))


@pytest.mark.parametrize("cap", [-1, 1.5, True, "3"])
def test_bad_expansion_limits_are_errors(cap: object) -> None:
    with pytest.raises(InvalidInputError, match="max_expansions"):
        GraphSearchOptions(max_expansions=cap)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="max_expansions"):
        GridSearchOptions(max_expansions=cap)  # type: ignore[arg-type]
        grid_search(_grid(), (0, 0), (4, 4), options=GridSearchOptions(max_expansions=cap))  # type: ignore[arg-type]


def test_sparse_matrix_must_be_square() -> None:
    with pytest.raises(InvalidInputError, match="square"):
        dijkstra(sp.csr_matrix(np.ones((2, 3))), 0, 1)


def test_valid_searches_match_scipy() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = 12
        dense = rng.uniform(0.1, 3.0, (n, n)) * (rng.random((n, n)) < 0.3)
        matrix = sp.csr_matrix(dense)
        ref = shortest_path(matrix, method="D", directed=True, indices=0)
        adj = [[(int(j), float(dense[i, j])) for j in np.flatnonzero(dense[i])] for i in range(n)]
        for graph in (matrix, adj):
            dist = dijkstra(graph, 0).distances
            for j in range(n):
                assert dist.get(j, math.inf) == pytest.approx(ref[j], rel=1e-12)
            res = astar(graph, 0, n - 1, np.zeros(n))
            assert res.cost == pytest.approx(ref[n - 1], rel=1e-12)


@pytest.mark.parametrize("cell", [(4.7, 4.2), (4.5, 4), (NAN, 4), (math.inf, 0), (True, 4), "ab"])
def test_grid_cells_must_be_integers(cell: object) -> None:
    grid = _grid()
    with pytest.raises(InvalidInputError, match="integers"):
        grid_search(grid, (0, 0), cell)
    with pytest.raises(InvalidInputError, match="integers"):
        wavefront(grid, cell)
    with pytest.raises(InvalidInputError, match="integers"):
        grid.in_bounds(cell)


def test_integral_cells_are_cells() -> None:
    grid = _grid()
    a = grid_search(grid, (0.0, 0.0), (4.0, np.int64(4)))
    b = grid_search(grid, (0, 0), (4, 4))
    assert a.cost == b.cost and np.array_equal(a.path, b.path)


def test_grid_values_must_be_finite() -> None:
    occ = np.zeros((3, 3))
    with pytest.raises(NotFiniteError):
        OccupancyGrid(occ, origin=(NAN, 0.0))
    occ[1, 1] = NAN
    with pytest.raises(InvalidInputError, match="NaN"):
        OccupancyGrid(occ)
