"""Optimization objectives: exact costs, and the optimal planners optimize what they are given."""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.objectives import Clearance, PathLength, WeightedSum
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

SQUARE = (0.4, 0.3, 0.6, 0.7)  # xmin, ymin, xmax, ymax


def square_distance(Q: np.ndarray) -> np.ndarray:
    """Exact Euclidean distance of each row to the square (0 inside)."""
    dx = np.maximum(np.maximum(SQUARE[0] - Q[:, 0], Q[:, 0] - SQUARE[2]), 0.0)
    dy = np.maximum(np.maximum(SQUARE[1] - Q[:, 1], Q[:, 1] - SQUARE[3]), 0.0)
    return np.hypot(dx, dy)


def square_world() -> ConfigurationSpace:
    return ConfigurationSpace(
        [0, 0],
        [1, 1],
        FunctionChecker(lambda Q: square_distance(Q) > 0),
        edge=EdgeCheckOptions(resolution=0.005),
    )


def free_world() -> ConfigurationSpace:
    return ConfigurationSpace([0, 0], [1, 1], FunctionChecker(lambda Q: np.ones(len(Q), bool)))


def test_path_length_and_weights_are_exact() -> None:
    a, b = np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([[3.0, 4.0], [1.0, 2.0]])
    np.testing.assert_allclose(PathLength().motion_costs(a, b), [5.0, 1.0])
    np.testing.assert_allclose(PathLength([2.0, 0.5]).motion_costs(a, b), [math.hypot(6, 2), 0.5])
    assert PathLength().is_euclidean_length and not PathLength([1, 2]).is_euclidean_length
    path = np.array([[0, 0], [3, 4], [3, 5]])
    assert PathLength().path_cost(path) == pytest.approx(6.0)
    with pytest.raises(InvalidInputError, match="weights must all be > 0"):
        PathLength([1.0, 0.0])


def test_clearance_integral_matches_the_analytic_value() -> None:
    """d(q) = q_x (a wall on x = 0): integral of 1 / (eps + x) dx = log((eps + b) / (eps + a))."""
    eps = 0.01
    objective = Clearance(lambda Q: Q[:, 0], epsilon=eps, resolution=1e-3)
    exact = math.log((eps + 0.5) / (eps + 0.1))
    assert objective.motion_cost(np.array([0.1, 0.3]), np.array([0.5, 0.3])) == pytest.approx(
        exact, rel=1e-4
    )
    # Symmetric, and a diagonal segment integrates along its length.
    a, b = np.array([0.1, 0.0]), np.array([0.5, 0.3])
    assert objective.motion_cost(a, b) == pytest.approx(objective.motion_cost(b, a))
    assert objective.motion_cost(a, b) == pytest.approx(exact * 0.5 / 0.4, rel=1e-4)
    combined = WeightedSum([(2.0, PathLength()), (0.5, objective)])
    assert combined.motion_cost(a, b) == pytest.approx(2 * 0.5 + 0.5 * exact * 1.25, rel=1e-4)
    with pytest.raises(InvalidInputError, match="not an OptimizationObjective"):
        WeightedSum([(1.0, "length")])  # type: ignore[list-item]


PLANNERS = {
    "rrt_star": lambda s, g, o: rrt_star(
        s, [0.1, 0.5], g, RRTStarOptions(max_iterations=600, time_limit_s=None), objective=o
    ),
    "prm_star": lambda s, g, o: prm_star(
        s, [0.1, 0.5], g, PRMStarOptions(max_iterations=300, time_limit_s=None), objective=o
    )[0],
    "lazy_prm_star": lambda s, g, o: lazy_prm_star(
        s, [0.1, 0.5], g, PRMStarOptions(max_iterations=300, time_limit_s=None), objective=o
    )[0],
    "bit_star": lambda s, g, o: bit_star(
        s, [0.1, 0.5], g, BITStarOptions(max_iterations=300, time_limit_s=None), objective=o
    ),
}


@pytest.mark.parametrize("name", list(PLANNERS))
def test_weighted_metric_chooses_the_goal_that_is_cheaper_in_that_metric(name: str) -> None:
    """Goals at dx = 0.8 and dy = 0.4: Euclidean picks the second, weights (1, 3) the first."""
    goals = np.array([[0.9, 0.5], [0.1, 0.9]])
    plain = PLANNERS[name](free_world(), goals, None)
    np.testing.assert_allclose(plain.path[-1], goals[1])
    assert plain.cost == pytest.approx(0.4, rel=0.02)
    weighted = PLANNERS[name](free_world(), goals, PathLength([1.0, 3.0]))
    np.testing.assert_allclose(weighted.path[-1], goals[0])
    assert weighted.cost == pytest.approx(0.8, rel=0.02)  # 3 x 0.4 = 1.2 the other way
    assert weighted.cost == pytest.approx(PathLength([1.0, 3.0]).path_cost(weighted.path))


@pytest.mark.parametrize("name", ["rrt_star", "lazy_prm_star", "bit_star"])
def test_clearance_objective_keeps_away_from_the_obstacle(name: str) -> None:
    """Length + clearance: cheaper (in that objective) than the shortest path, and farther away.

    The shortest path touches the square's corners (analytic: through (0.4, 0.3) and
    (0.6, 0.3)); the planner must find a path whose combined cost is lower than that path's,
    which a length-minimizing planner cannot.
    """
    clearance = Clearance(square_distance, epsilon=0.02, resolution=0.01, max_clearance=0.8)
    objective = WeightedSum([(1.0, PathLength()), (0.05, clearance)])
    shortest = np.array([[0.1, 0.5], [0.4, 0.3], [0.6, 0.3], [0.9, 0.5]])
    result = PLANNERS[name](square_world(), [0.9, 0.5], objective)
    assert result.success and square_world().path_valid(result.path)
    assert result.cost == pytest.approx(objective.path_cost(result.path))
    assert result.cost < objective.path_cost(shortest)
    dense = np.vstack(
        [a + t[:, None] * (b - a) for a, b in zip(result.path[:-1], result.path[1:])
         for t in [np.linspace(0, 1, 50)]]
    )  # fmt: skip
    assert square_distance(dense).min() > 0.02  # the shortest path touches the square


def test_objective_type_is_checked() -> None:
    with pytest.raises(InvalidInputError, match="objective must be an OptimizationObjective"):
        bit_star(free_world(), [0.1, 0.1], [0.9, 0.9], objective="length")  # type: ignore[arg-type]
