import math
from collections import deque

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra as scipy_dijkstra

from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.graph_search import SearchStatus, astar, dijkstra
from taskspace.planning.grid import (
    GridSearchOptions,
    GridStatus,
    OccupancyGrid,
    grid_search,
    wavefront,
    wavefront_path,
)

N4 = [(-1, 0), (1, 0), (0, -1), (0, 1)]
N8 = [*N4, (-1, -1), (-1, 1), (1, -1), (1, 1)]


def bfs_reference(occ, goal, nbrs):
    """Plain BFS, textbook style: number of moves from goal to every cell (-1 if none)."""
    dist = -np.ones(occ.shape, int)
    dist[goal] = 0
    q = deque([goal])
    while q:
        r, c = q.popleft()
        for dr, dc in nbrs:
            rr, cc = r + dr, c + dc
            if 0 <= rr < occ.shape[0] and 0 <= cc < occ.shape[1] and not occ[rr, cc]:
                if dist[rr, cc] < 0:
                    dist[rr, cc] = dist[r, c] + 1
                    q.append((rr, cc))
    return dist


def scipy_grid_costs(occ, start, nbrs, corner_cutting):
    rows, cols = occ.shape
    idx = lambda r, c: r * cols + c  # noqa: E731
    I, J, W = [], [], []
    for r in range(rows):
        for c in range(cols):
            if occ[r, c]:
                continue
            for dr, dc in nbrs:
                rr, cc = r + dr, c + dc
                if not (0 <= rr < rows and 0 <= cc < cols) or occ[rr, cc]:
                    continue
                if dr and dc and not corner_cutting and (occ[r + dr, c] or occ[r, c + dc]):
                    continue
                I.append(idx(r, c))
                J.append(idx(rr, cc))
                W.append(math.hypot(dr, dc))
    m = sp.csr_matrix((W, (I, J)), shape=(rows * cols, rows * cols))
    return scipy_dijkstra(m, indices=idx(*start)).reshape(rows, cols)


def random_grid(seed, shape=(25, 30), density=0.3):
    rng = np.random.default_rng(seed)
    occ = rng.random(shape) < density
    occ[0, 0] = occ[-1, -1] = False
    return occ


# The example of slides 3:19-3:24 style: a wall with a gap.
SLIDE_GRID = np.array(
    [
        [0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 1, 0, 0, 0],
        [0, 0, 0, 1, 0, 0, 0],
        [0, 0, 0, 1, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0],
    ],
    dtype=bool,
)


@pytest.mark.parametrize("connectivity", [4, 8])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wavefront_equals_brute_force_bfs(connectivity, seed):
    occ = random_grid(seed)
    res = wavefront(OccupancyGrid(occ), (12, 15), connectivity=connectivity)
    ref = bfs_reference(occ, (12, 15), N4 if connectivity == 4 else N8)
    np.testing.assert_array_equal(res.distance, np.where(occ, -1, ref))
    # slide labels: obstacles 1, goal 2, unreachable 0, else 2 + moves
    assert res.values[12, 15] == 2
    assert np.all(res.values[occ] == 1)
    assert np.all(res.values[(~occ) & (ref < 0)] == 0)
    np.testing.assert_array_equal(res.values[ref >= 0], ref[ref >= 0] + 2)


def test_wavefront_slide_numbers_and_descent():
    res = wavefront(OccupancyGrid(SLIDE_GRID), (2, 6), connectivity=8)
    assert res.values[2, 5] == 3 and res.values[1, 4] == 4
    assert res.values[0, 3] == 5  # over the wall diagonally
    path = wavefront_path(res, (2, 0))
    assert path.success and path.cost == res.distance[2, 0]
    # each step lowers the label by one and is an 8-neighbour move
    labels = res.values[path.path[:, 0], path.path[:, 1]]
    np.testing.assert_array_equal(np.diff(labels), -1)
    assert np.all(np.abs(np.diff(path.path, axis=0)).max(axis=1) == 1)


def test_wavefront_unreachable_region_stays_zero():
    occ = np.zeros((5, 5), bool)
    occ[:, 2] = True
    res = wavefront(OccupancyGrid(occ), (0, 0), connectivity=8)
    assert np.all(res.values[:, 3:] == 0)
    p = wavefront_path(res, (4, 4))
    assert not p.success and p.status is GridStatus.UNREACHABLE and p.path.shape == (0, 2)


@pytest.mark.parametrize("connectivity", [4, 8])
@pytest.mark.parametrize("corner_cutting", [False, True])
@pytest.mark.parametrize("seed", [3, 4])
def test_astar_and_dijkstra_match_scipy_dijkstra(connectivity, corner_cutting, seed):
    occ = random_grid(seed, (20, 22), 0.25)
    g = OccupancyGrid(occ)
    nbrs = N4 if connectivity == 4 else N8
    ref = scipy_grid_costs(occ, (0, 0), nbrs, corner_cutting)
    opts = GridSearchOptions(connectivity=connectivity, corner_cutting=corner_cutting)
    rng = np.random.default_rng(seed)
    free = np.argwhere(~occ)
    for goal in free[rng.choice(len(free), 8, replace=False)]:
        a = grid_search(g, (0, 0), goal, method="astar", options=opts)
        d = grid_search(g, (0, 0), goal, method="dijkstra", options=opts)
        r = ref[tuple(goal)]
        if np.isinf(r):
            assert not a.success and a.status is GridStatus.UNREACHABLE and np.isinf(a.cost)
            assert not d.success
            continue
        assert a.cost == pytest.approx(r, abs=1e-9)
        assert d.cost == pytest.approx(r, abs=1e-9)
        assert a.expanded <= d.expanded
        # the path itself is valid and its length equals the cost
        steps = np.diff(a.path, axis=0)
        assert np.all(~occ[a.path[:, 0], a.path[:, 1]])
        assert np.sum(np.hypot(steps[:, 0], steps[:, 1])) == pytest.approx(r, abs=1e-9)
        assert tuple(a.path[0]) == (0, 0) and tuple(a.path[-1]) == tuple(goal)


def test_generic_graph_search_accepts_csr_adjacency_list_and_callable():
    rng = np.random.default_rng(7)
    n = 40
    dense = np.where(rng.random((n, n)) < 0.1, rng.uniform(0.1, 5.0, (n, n)), 0.0)
    csr = sp.csr_matrix(dense)
    ref = scipy_dijkstra(csr, indices=0)
    adj = [[(j, dense[i, j]) for j in np.flatnonzero(dense[i])] for i in range(n)]
    full = dijkstra(csr, 0)
    assert full.success and full.status is SearchStatus.EXHAUSTED
    for j in range(n):
        assert full.distances.get(j, np.inf) == pytest.approx(ref[j])
    for goal in range(1, n):
        for graph in (csr, adj, lambda i: adj[i]):
            res = dijkstra(graph, 0, goal)
            if np.isinf(ref[goal]):
                assert res.status is SearchStatus.UNREACHABLE and res.path == []
            else:
                assert res.cost == pytest.approx(ref[goal])
                assert res.path[0] == 0 and res.path[-1] == goal
        # A* with a zero heuristic array and an admissible one (half the true cost-to-go)
        to_goal = scipy_dijkstra(csr.T.tocsr(), indices=goal)
        h = np.where(np.isinf(to_goal), 0.0, 0.5 * to_goal)
        res = astar(csr, 0, goal, h)
        assert res.cost == pytest.approx(ref[goal])


def test_weighted_astar_bounded_suboptimality_and_expansion_limit():
    occ = random_grid(5, (40, 40), 0.2)
    g = OccupancyGrid(occ)
    best = grid_search(g, (0, 0), (39, 39)).cost
    w = grid_search(g, (0, 0), (39, 39), options=GridSearchOptions(heuristic_weight=2.0))
    assert best <= w.cost <= 2.0 * best + 1e-9
    lim = grid_search(g, (0, 0), (39, 39), options=GridSearchOptions(max_expansions=5))
    assert not lim.success and lim.status is GridStatus.EXPANSION_LIMIT


def test_errors_have_clear_messages():
    g = OccupancyGrid(SLIDE_GRID)
    with pytest.raises(
        PlanningError, match=r"start cell \(9, 0\) is outside the grid of shape \(5, 7\)"
    ):
        grid_search(g, (9, 0), (0, 0))
    with pytest.raises(PlanningError, match=r"goal cell \(1, 3\) is inside an obstacle"):
        grid_search(g, (0, 0), (1, 3))
    with pytest.raises(PlanningError, match=r"goal cell .* is inside an obstacle"):
        wavefront(g, (2, 3))
    with pytest.raises(PlanningError, match=r"start cell .* outside"):
        wavefront_path(wavefront(g, (0, 0)), (0, -1))
    with pytest.raises(InvalidInputError, match="connectivity must be 4 or 8"):
        wavefront(g, (0, 0), connectivity=6)  # type: ignore[arg-type]
    with pytest.raises(UnknownNameError, match="valid methods are: astar, dijkstra"):
        grid_search(g, (0, 0), (0, 1), method="bfs")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="negative cost"):
        dijkstra([[(1, -1.0)], []], 0, 1)
    with pytest.raises(InvalidInputError, match="non-empty 2-D array"):
        OccupancyGrid(np.zeros(3, bool))


def test_world_cell_conversion():
    g = OccupancyGrid(np.zeros((4, 6), bool), resolution=0.5, origin=(-1.0, 2.0))
    assert g.cell_of((0.1, 2.6)) == (1, 2)
    np.testing.assert_allclose(g.center_of((1, 2)), [0.25, 2.75])
