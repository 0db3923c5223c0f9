"""RRT* in high dimensions: pruning saves the rewiring edges that cannot improve the path.

Problem: a ball of radius ``R`` in a 30-D box between a start and a goal at distance ``D``
from its centre. The shortest path is known in closed form (two tangent segments and a great
arc): ``L* = 2 sqrt(D^2 - R^2) + R (pi - 2 acos(R / D))``, a lower bound on every valid
path's length; every returned segment is checked against the ball analytically (its closest
point to the centre), not by the planner's checker.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

D, R, DIM, RES = 1.0, 0.6, 30, 0.02
OPTIMUM = 2 * math.sqrt(D * D - R * R) + R * (math.pi - 2 * math.acos(R / D))


def _ball_space() -> tuple[ConfigurationSpace, np.ndarray, np.ndarray]:
    def free(q: np.ndarray) -> np.ndarray:
        return np.asarray(np.linalg.norm(q, axis=1) > R)

    space = ConfigurationSpace(
        -1.5 * np.ones(DIM), 1.5 * np.ones(DIM), FunctionChecker(free),
        edge=EdgeCheckOptions(resolution=RES),
    )  # fmt: skip
    start, goal = np.zeros(DIM), np.zeros(DIM)
    start[0], goal[0] = -D, D
    return space, start, goal


def _segment_clearance(path: np.ndarray) -> float:
    """Least distance from the ball's centre (the origin) to the path's segments."""
    a, b = path[:-1], path[1:]
    ab = b - a
    t = np.clip(-np.einsum("ij,ij->i", a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(a + t[:, None] * ab, axis=1).min())


@pytest.mark.parametrize("informed", [False, True])
def test_pruning_saves_checks_without_losing_cost_in_30_dimensions(informed: bool) -> None:
    space, start, goal = _ball_space()
    results = {}
    for prune in (False, True):
        opts = RRTStarOptions(
            max_iterations=1000, time_limit_s=None, seed=0, prune=prune, informed=informed
        )
        results[prune] = rrt_star(space, start, goal, opts)
    plain, pruned = results[False], results[True]
    for res in (plain, pruned):
        assert res.success
        np.testing.assert_array_equal(res.path[0], start)
        np.testing.assert_array_equal(res.path[-1], goal)
        # free between the checked points up to the sagitta of a RES chord on the ball
        assert _segment_clearance(res.path) > R - RES**2 / (8 * R) - 1e-12
        assert res.cost >= OPTIMUM - 1e-9  # no valid path is shorter
        assert res.cost == pytest.approx(
            float(np.linalg.norm(np.diff(res.path, axis=0), axis=1).sum())
        )
    assert pruned.log["pruned_samples"] + pruned.log["pruned_rewires"] > 0
    assert pruned.cost <= plain.cost * 1.02
    assert pruned.collision_checks < 0.5 * plain.collision_checks
    assert pruned.cost < pruned.log["costs"][0]  # rewiring still improves the first path


def test_high_dof_rrt_star_stops_at_its_time_limit_with_a_path() -> None:
    space, start, goal = _ball_space()
    res = rrt_star(space, start, goal, RRTStarOptions(max_iterations=None, time_limit_s=0.3))
    assert res.success and res.log["stopped_by"] == "time"
    assert _segment_clearance(res.path) > R - RES**2 / (8 * R) - 1e-12
