"""RRT* with RRT-Connect's first solution: a valid branch, rewired toward the analytic optimum."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

RESOLUTION = 0.002
BOX = (0.4, 0.6, 0.3, 0.7)  # x_min, x_max, y_min, y_max of the square obstacle
OPTIMUM_2D = 2 * math.hypot(0.3, 0.2) + 0.2  # around a corner pair of the square


def square_world() -> ConfigurationSpace:
    x0, x1, y0, y1 = BOX

    def free(Q: np.ndarray) -> np.ndarray:
        return ~((Q[:, 0] > x0) & (Q[:, 0] < x1) & (Q[:, 1] > y0) & (Q[:, 1] < y1))

    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=RESOLUTION)
    )


def segment_hits_box(a: np.ndarray, b: np.ndarray, box: tuple[float, ...]) -> bool:
    """Exact Liang-Barsky clip of the segment ``a b`` against the open box."""
    t0, t1 = 0.0, 1.0
    d = b - a
    for p, q in (
        (-d[0], a[0] - box[0]),
        (d[0], box[1] - a[0]),
        (-d[1], a[1] - box[2]),
        (d[1], box[3] - a[1]),
    ):
        if p == 0:
            if q <= 0:
                return False
            continue
        r = q / p
        if p < 0:
            t0 = max(t0, r)
        else:
            t1 = min(t1, r)
    return t0 < t1


def test_first_path_is_a_valid_branch_that_rewiring_shortens() -> None:
    space = square_world()
    opts = RRTStarOptions(step_size=0.2, max_iterations=3000, time_limit_s=None, seed=3)
    result = rrt_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert result.success
    assert result.log["first_solution_by"] == "rrt_connect"
    # Every tree edge (RRT-Connect's branch and RRT*'s own) misses the square shrunk by the
    # checking resolution, exactly: a deeper cut would have put a checked point inside.
    tree = result.trees[0]
    shrunk = (BOX[0] + RESOLUTION, BOX[1] - RESOLUTION, BOX[2] + RESOLUTION, BOX[3] - RESOLUTION)
    for a, b in tree.edges():
        assert not segment_hits_box(a, b, shrunk)
    path = result.path
    np.testing.assert_allclose(path[0], [0.1, 0.5])
    np.testing.assert_allclose(path[-1], [0.9, 0.5])
    # The reported cost is the path's length, summed here independently of the tree's costs.
    length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    assert result.cost == pytest.approx(length, rel=1e-12)
    costs = result.log["costs"]
    assert all(b < a for a, b in itertools.pairwise(costs))
    assert costs[0] > length  # RRT-Connect's path was improved by rewiring
    assert OPTIMUM_2D - 1e-9 <= length <= OPTIMUM_2D * 1.03


def test_free_7d_box_first_path_is_the_straight_line() -> None:
    space = ConfigurationSpace(
        -np.pi * np.ones(7), np.pi * np.ones(7), FunctionChecker(lambda Q: np.ones(len(Q), bool))
    )
    start = -2.0 * np.ones(7)
    goal = 2.0 * np.array([1, -1, 1, -1, 1, -1, 1.0])
    result = rrt_star(space, start, goal, RRTStarOptions(max_iterations=500, time_limit_s=None))
    assert result.success
    assert result.cost == pytest.approx(float(np.linalg.norm(goal - start)), rel=1e-9)
    assert result.log["stopped_by"] == "optimal"
    assert result.iterations <= 500


def test_iterations_of_rrt_connect_count_toward_the_cap() -> None:
    space = square_world()
    opts = RRTStarOptions(step_size=0.05, max_iterations=3, time_limit_s=None)
    result = rrt_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert result.iterations <= 3


def test_plain_rrt_star_first_solution_and_bad_names() -> None:
    space = square_world()
    opts = RRTStarOptions(
        step_size=0.2, max_iterations=400, time_limit_s=None, first_solution="rrt_star"
    )
    result = rrt_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert result.log["first_solution_by"] == "rrt_star"
    with pytest.raises(InvalidInputError, match="rrt_connect, rrt_star"):
        rrt_star(space, [0.1, 0.5], [0.9, 0.5], RRTStarOptions(first_solution="connect"))


def test_several_goals_rrt_connect_aims_at_the_nearest_then_rrt_star_finds_the_cheaper() -> None:
    space = square_world()
    start = np.array([0.1, 0.5])
    # the nearer goal (0.8 away) lies behind the square (about 0.92 around it); the farther
    # one (0.854 away) is reached by a straight line above the square: the optimum
    goals = np.array([[0.9, 0.5], [0.8, 0.99]])
    free = float(np.linalg.norm(goals[1] - start))
    assert space.path_valid(np.stack([start, goals[1]]))
    assert not space.path_valid(np.stack([start, goals[0]]))
    opts = RRTStarOptions(step_size=0.2, max_iterations=2000, time_limit_s=None, seed=0)
    result = rrt_star(space, start, goals, opts)
    assert result.success
    assert result.log["first_solution_by"] == "rrt_connect"
    assert result.log["costs"][0] > OPTIMUM_2D - 1e-9  # the first path went around the square
    np.testing.assert_allclose(result.path[-1], goals[1])
    length = float(np.linalg.norm(np.diff(result.path, axis=0), axis=1).sum())
    assert result.cost == pytest.approx(length, rel=1e-12)
    assert free - 1e-9 <= length <= free * 1.03
