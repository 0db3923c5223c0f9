"""PRM (uniform, Gaussian, bridge sampling) and Lazy PRM, against scipy's shortest paths."""

from __future__ import annotations

from typing import Literal

import numpy as np
import pytest
from scipy.sparse import lil_matrix
from scipy.sparse.csgraph import shortest_path

from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.sampling import sample_free
from tests.planning._planning_worlds import WALL, wall_space

START, GOAL = np.array([1.0, 1.0]), np.array([9.0, 9.0])


def _reference_cost(space, roadmap, q_s, q_g, k):  # type: ignore[no-untyped-def]
    """Shortest path cost with start/goal attached, by scipy (Dijkstra) on a sparse matrix."""
    n = roadmap.size
    mat = lil_matrix((n + 2, n + 2))
    for i, nb in enumerate(roadmap.adjacency):
        for j, c in nb:
            mat[i, j] = c
    for row, q in ((n, q_s), (n + 1, q_g)):
        d = np.linalg.norm(roadmap.nodes - q, axis=1)
        for j in np.argsort(d)[:k]:
            if space.motion_valid(q, roadmap.nodes[j]):
                mat[row, j] = mat[j, row] = d[j]
    if space.motion_valid(q_s, q_g):
        mat[n, n + 1] = mat[n + 1, n] = np.linalg.norm(q_g - q_s)
    return shortest_path(mat.tocsr(), directed=False, indices=n)[n + 1]


@pytest.mark.parametrize("search", ["dijkstra", "astar"])
def test_prm_queries_equal_reference_shortest_paths(search: Literal["dijkstra", "astar"]) -> None:
    space = wall_space(resolution=0.05)
    opts = PRMOptions(max_iterations=300, k_neighbors=8, search=search, seed=3)
    roadmap = build_prm(space, opts)
    assert roadmap.size == 300
    rng = np.random.default_rng(0)
    queries = [(START, GOAL)] + [tuple(sample_free(space, 2, rng)) for _ in range(4)]
    n_edges = roadmap.edges.shape[0]
    for q_s, q_g in queries:
        res = prm_query(space, roadmap, q_s, q_g, opts)
        ref = _reference_cost(space, roadmap, q_s, q_g, 8)
        if np.isfinite(ref):
            assert res.success
            assert res.path_length == pytest.approx(ref, rel=1e-9)
            assert wall_space(resolution=0.005).path_valid(res.path)
        else:
            assert not res.success
    assert roadmap.edges.shape[0] == n_edges  # queries do not modify the roadmap


def test_prm_edges_are_free() -> None:
    space = wall_space(resolution=0.05)
    res, roadmap = prm(space, START, GOAL, PRMOptions(max_iterations=200, seed=1))
    assert res.success
    fine = wall_space(resolution=0.005)
    for i, j in roadmap.edges[:200]:
        assert fine.motion_valid(roadmap.nodes[i], roadmap.nodes[j])


def test_samplers_concentrate_near_obstacles() -> None:
    space = wall_space()
    rng = np.random.default_rng(0)
    uniform = sample_free(space, 400, rng, strategy="uniform")
    gauss = sample_free(space, 400, rng, strategy="gaussian", sigma=0.3)
    bridge = sample_free(space, 100, rng, strategy="bridge", sigma=1.5)
    assert np.all(space.checker.are_valid(gauss)) and np.all(space.checker.are_valid(bridge))

    def near_wall(q: np.ndarray) -> float:
        return float(np.mean(np.abs(q[:, 0] - 5.0) < 1.0))

    assert near_wall(gauss) > 2 * near_wall(uniform)
    # Bridge samples sit between two colliding points: in the gap of the wall.
    in_gap = (np.abs(bridge[:, 0] - 5.0) < 1.0) & (bridge[:, 1] > 4.0) & (bridge[:, 1] < 6.0)
    assert in_gap.mean() > 0.5
    with pytest.raises(UnknownNameError, match="valid samplers are: bridge, gaussian, uniform"):
        sample_free(space, 10, rng, strategy="sobol")  # type: ignore[arg-type]


def test_lazy_prm_matches_checked_prm_and_checks_fewer_edges() -> None:
    space = wall_space(resolution=0.05)
    opts = PRMOptions(max_iterations=300, k_neighbors=8, seed=4)
    lazy = build_lazy_prm(space, opts)
    res = lazy_prm_query(space, lazy, START, GOAL, opts)
    assert res.success
    assert wall_space(resolution=0.005).path_valid(res.path)
    full = build_prm(space, opts)  # same seed: same nodes
    np.testing.assert_array_equal(full.nodes, lazy.roadmap.nodes)
    ref = prm_query(space, full, START, GOAL, opts)
    assert res.path_length == pytest.approx(ref.path_length, rel=1e-9)
    assert res.edge_checks < full.edges_tried
    again = lazy_prm_query(space, lazy, START, GOAL, opts)  # cached edges: no new edge check
    assert again.path_length == pytest.approx(res.path_length) and again.edge_checks <= 2 * 8 + 1


def test_prm_start_in_collision() -> None:
    space = wall_space()
    roadmap = build_prm(space, PRMOptions(max_iterations=50))
    with pytest.raises(PlanningError, match="start is in collision"):
        prm_query(space, roadmap, [5.0, 1.0], GOAL)
    assert WALL.shape == (2, 4)


def test_single_query_lazy_prm_grows_until_connected() -> None:
    from taskspace.planning.lazy_prm import lazy_prm

    space = wall_space(resolution=0.05)
    # 20 nodes rarely connect start and goal through the gap: the roadmap must grow.
    res, lazy = lazy_prm(
        space, START, GOAL,
        PRMOptions(batch_size=20, max_iterations=2000, k_neighbors=6, seed=0, time_limit_s=1.0),
    )  # fmt: skip
    assert res.success and res.log["growth_rounds"] >= 1
    assert lazy.roadmap.size == 20 * res.log["growth_rounds"]
    assert wall_space(resolution=0.005).path_valid(res.path)
    # The answer is the shortest path of the fully checked roadmap (same nodes, same k).
    nodes = lazy.roadmap.nodes
    adjacency = [[] for _ in range(len(nodes))]  # type: ignore[var-annotated]
    for (i, j), c in zip(lazy.pairs.tolist(), lazy.costs.tolist()):
        if space.motion_valid(nodes[i], nodes[j]):
            adjacency[i].append((j, c))
            adjacency[j].append((i, c))
    from taskspace.planning.prm import Roadmap

    full = Roadmap(nodes=nodes, adjacency=adjacency)
    ref = _reference_cost(space, full, START, GOAL, 6)
    assert res.path_length == pytest.approx(ref, rel=1e-9)


def test_deprecated_limit_names_still_work_with_a_warning() -> None:
    """``PRMOptions.n_samples`` and ``lazy_prm(max_rounds=...)`` keep their old meaning."""
    space = wall_space()
    with pytest.warns(DeprecationWarning, match="n_samples is deprecated: use max_iterations"):
        old = PRMOptions(n_samples=40, seed=2)
    assert build_prm(space, old).size == 40  # PRM: the roadmap size
    assert build_prm(space, PRMOptions(max_iterations=40, seed=2)).size == 40
    assert build_lazy_prm(space, old).roadmap.size == 40
    with pytest.warns(DeprecationWarning, match="max_rounds=.... is deprecated"):
        res, lazy = lazy_prm(
            space, START, GOAL, PRMOptions(batch_size=10, seed=0), max_rounds=2,
            time_limit_s=None,
        )  # fmt: skip
    # Lazy PRM: n_samples was the nodes per round, max_rounds the rounds
    assert res.log["growth_rounds"] <= 2 and lazy.roadmap.size <= 20
    assert res.iterations <= 20
    with pytest.warns(DeprecationWarning):
        res, lazy = lazy_prm(space, START, GOAL, PRMOptions(n_samples=15, seed=0), max_rounds=1)
    assert res.log["growth_rounds"] == 1 and lazy.roadmap.size <= 15
    with pytest.raises(InvalidInputError, match="max_iterations=None"):
        build_prm(space, PRMOptions(max_iterations=None))
