"""Lazy PRM*'s expansion step (random-bounce walks from the nodes whose *checked* edges failed,
until a first path): its free edges are free, it reaches a goal down a narrow corridor more
often, and Lazy PRM* still converges.

References: every edge the lazy roadmap holds as free (the walks' chains included) and the
path are tested against the obstacles exactly (Liang-Barsky segment-versus-box, or a dense
test against the corridor grown by the resolution); the square problem's optimum is analytic.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star
from tests.planning.test_planning_prm_star_expansion import _corridor
from tests.planning.test_planning_rrt_connect_goals import _exactly_free, _space

START = np.array([0.1, 0.5])
CUP = np.array([0.8, 0.5])  # inside a cup open to the left (test_planning_rrt_connect_goals)


def test_free_edges_and_the_path_are_free() -> None:
    space = _space()
    opts = PRMStarOptions(max_iterations=300, time_limit_s=None, seed=0, expand_fraction=1.0)
    res, lazy = lazy_prm_star(space, START, CUP, opts)
    assert res.log["expansion_nodes"] > 0
    nodes = lazy.roadmap.nodes
    free = lazy.pairs[lazy.status > 0]
    assert free.shape[0] > 10
    for i, j in free.tolist():
        assert _exactly_free(nodes[[i, j]]), (nodes[i], nodes[j])
    assert all(_exactly_free(np.stack([q, q])) for q in nodes)  # every node free
    assert res.success and _exactly_free(res.path)


def _corridor_space() -> ConfigurationSpace:
    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(_corridor), edge=EdgeCheckOptions(resolution=0.005)
    )


def test_expansion_reaches_a_goal_down_a_corridor_more_often() -> None:
    space = _corridor_space()
    start, goal = np.array([0.1, 0.5]), np.array([0.88, 0.25])
    wins = {}
    for fraction in (0.0, 0.5):
        found = []
        for seed in range(10):
            opts = PRMStarOptions(
                max_iterations=128, batch_size=32, time_limit_s=None, seed=seed,
                expand_fraction=fraction, stop_at_first=True,
            )  # fmt: skip
            res, _ = lazy_prm_star(space, start, goal, opts)
            if res.success:  # free (to the resolution) every 1e-4 along the path
                for a, b in itertools.pairwise(res.path):
                    n = max(1, math.ceil(np.linalg.norm(b - a) / 1e-4))
                    t = np.arange(n + 1)[:, None] / n
                    assert _corridor(a + t * (b - a), grow=0.005).all()
            else:
                assert res.log["expansion_nodes"] > 0 or fraction == 0.0
            found.append(res.success)
        wins[fraction] = sum(found)
    assert wins[0.5] > wins[0.0], wins


def test_no_walk_after_the_first_path_and_convergence_on_the_square() -> None:
    """The square [0.4, 0.6] x [0.3, 0.7] in [0, 1]^2: optimum 2 hypot(0.3, 0.2) + 0.2."""

    def free(q: np.ndarray) -> np.ndarray:
        return ~((q[:, 0] > 0.4) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.7))

    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.005)
    )
    optimum = 2 * math.hypot(0.3, 0.2) + 0.2
    opts = PRMStarOptions(max_iterations=1500, time_limit_s=None, seed=1, expand_fraction=0.5)
    res, _ = lazy_prm_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert res.success
    assert optimum - 1e-9 <= res.cost <= optimum * 1.03
    costs = res.log["costs"]
    assert all(a > b for a, b in itertools.pairwise(costs))
    # walks only until the first path: at most one batch's worth (half of 64 samples)
    assert res.log["expansion_nodes"] <= 32
