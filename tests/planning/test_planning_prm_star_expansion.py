"""PRM*'s expansion step (random-bounce walks from nodes that fail to connect, Kavraki et al.
1996, as OMPL's PRM/PRMstar): its edges are free, it reaches a goal in a tight cup that
uniform samples rarely connect, and PRM* still converges.

References: every roadmap edge (the walks' chains included) is tested against the boxes by an
exact segment-versus-box test (Liang-Barsky); the optimum of the 2-D square problem is
analytic.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.prm_star import PRMStarOptions, prm_star
from tests.planning.test_planning_rrt_connect_goals import _exactly_free, _space

START = np.array([0.1, 0.5])
CUP = np.array([0.8, 0.5])  # inside the cup x in [0.7, 0.95], y in [0.35, 0.65], open to the left


def test_every_roadmap_edge_and_the_path_are_free() -> None:
    space = _space()
    opts = PRMStarOptions(max_iterations=300, time_limit_s=None, seed=0, expand_fraction=1.0)
    res, roadmap = prm_star(space, START, CUP, opts)
    assert res.log["expansion_nodes"] > 0
    nodes = roadmap.nodes
    edges = roadmap.edges
    assert edges.shape[0] > 100
    for i, j in edges.tolist():
        assert _exactly_free(nodes[[i, j]]), (nodes[i], nodes[j])
    assert all(_exactly_free(np.stack([q, q])) for q in nodes)  # every node free
    if res.success:
        assert _exactly_free(res.path)


def _corridor(q: np.ndarray, grow: float = 0.0) -> np.ndarray:
    """Free: x < 0.6, and an L-shaped corridor 0.04 wide to a goal at (0.88, 0.25).

    ``grow`` widens the free set (the reference check of edges checked at a resolution:
    an edge may cut a corner between its checked points by less than the resolution).
    """
    x, y, g = q[:, 0], q[:, 1], grow
    along = (0.48 - g < y) & (y < 0.52 + g) & (x < 0.9 + g)
    down = (0.86 - g < x) & (x < 0.9 + g) & (0.2 - g < y) & (y < 0.52 + g)
    return np.asarray((x < 0.6 + g) | along | down)


def test_expansion_reaches_a_goal_down_a_corridor_more_often() -> None:
    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(_corridor), edge=EdgeCheckOptions(resolution=0.005)
    )
    start, goal = np.array([0.1, 0.5]), np.array([0.88, 0.25])
    wins = {}
    for fraction in (0.0, 0.25):
        found = []
        for seed in range(10):
            opts = PRMStarOptions(
                max_iterations=128, batch_size=32, time_limit_s=None, seed=seed,
                expand_fraction=fraction, stop_at_first=True,
            )  # fmt: skip
            res, _ = prm_star(space, start, goal, opts)
            if res.success:  # free (to the resolution) every 1e-4 along the path
                for a, b in itertools.pairwise(res.path):
                    n = max(1, math.ceil(np.linalg.norm(b - a) / 1e-4))
                    t = np.arange(n + 1)[:, None] / n
                    assert _corridor(a + t * (b - a), grow=0.005).all()
            found.append(res.success)
        wins[fraction] = sum(found)
    assert wins[0.25] > wins[0.0]  # 9 of 10 against 6 of 10 (seeded)


def test_prm_star_with_expansion_converges_on_the_square() -> None:
    """The square [0.4, 0.6] x [0.3, 0.7] in [0, 1]^2: optimum 2 hypot(0.3, 0.2) + 0.2."""

    def free(q: np.ndarray) -> np.ndarray:
        return ~((q[:, 0] > 0.4) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.7))

    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.005)
    )
    optimum = 2 * math.hypot(0.3, 0.2) + 0.2
    opts = PRMStarOptions(max_iterations=1500, time_limit_s=None, seed=1, expand_fraction=0.5)
    res, _ = prm_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert res.success
    assert optimum - 1e-9 <= res.cost <= optimum * 1.03
    costs = res.log["costs"]
    assert all(a > b for a, b in itertools.pairwise(costs))


def test_bad_expand_fraction_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="expand_fraction"):
        prm_star(_space(), START, CUP, PRMStarOptions(expand_fraction=1.5))
