"""RRT* and informed RRT* converge toward analytic optima (2-D and 7-D)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, PlanningError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_star import (
    RRTStarOptions,
    _rotation_to_world,
    informed_sample,
    interpolate,
    rrt_star,
)


def square_world() -> ConfigurationSpace:
    """[0,1]^2 with the square obstacle [0.4,0.6]x[0.3,0.7]."""

    def free(Q: np.ndarray) -> np.ndarray:
        inside = (Q[:, 0] > 0.4) & (Q[:, 0] < 0.6) & (Q[:, 1] > 0.3) & (Q[:, 1] < 0.7)
        return ~inside

    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.002)
    )


OPTIMUM_2D = 2 * math.hypot(0.3, 0.2) + 0.2  # over a corner pair of the square


@pytest.mark.parametrize("informed", [False, True])
def test_converges_toward_the_shortest_path_around_a_square(informed: bool) -> None:
    space = square_world()
    opts = RRTStarOptions(
        step_size=0.2, max_iterations=3000, time_limit_s=None, informed=informed, seed=1
    )
    result = rrt_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert result.success
    assert space.path_valid(result.path)  # at the planner's resolution (2 mm)
    costs = result.log["costs"]
    assert all(b < a for a, b in itertools.pairwise(costs))  # anytime: only improves
    assert result.path_length == pytest.approx(costs[-1])
    assert OPTIMUM_2D - 1e-9 <= result.path_length <= OPTIMUM_2D * 1.03
    assert costs[0] > result.path_length  # it did improve on the first solution


def test_near_optimal_in_a_free_7d_box() -> None:
    """Free 7-D box: the optimum is the straight line."""
    space = ConfigurationSpace(
        -np.pi * np.ones(7), np.pi * np.ones(7), FunctionChecker(lambda Q: np.ones(len(Q), bool))
    )
    start, goal = -2.0 * np.ones(7), 2.0 * np.ones(7) * np.array([1, -1, 1, -1, 1, -1, 1])
    optimum = float(np.linalg.norm(goal - start))
    lengths = {}
    for informed in (False, True):
        opts = RRTStarOptions(
            step_size=1.0, max_iterations=1000, time_limit_s=None, informed=informed, seed=3
        )
        result = rrt_star(space, start, goal, opts)
        assert result.success
        lengths[informed] = result.path_length
        assert optimum - 1e-9 <= result.path_length
    assert lengths[True] <= optimum * 1.15  # 7-D RRT* converges slowly: 9.04 vs 8 here
    assert lengths[True] <= lengths[False]


def test_informed_samples_lie_in_the_ellipsoid_and_fill_it() -> None:
    rng = np.random.default_rng(0)
    start, goal = np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, -1.0])
    c_best = 1.3 * np.linalg.norm(goal - start)
    C = _rotation_to_world(start, goal)
    assert np.allclose(C @ C.T, np.eye(3)) and np.isclose(np.linalg.det(C), 1)
    x = np.array([informed_sample(rng, start, goal, c_best, C) for _ in range(4000)])
    focal = np.linalg.norm(x - start, axis=1) + np.linalg.norm(x - goal, axis=1)
    assert np.all(focal <= c_best + 1e-9)
    # uniform: the fraction inside the half-size ellipsoid is 1/8 (volume ratio in 3-D)
    center = (start + goal) / 2
    local = (x - center) @ C
    c_min = np.linalg.norm(goal - start)
    radii = np.array([c_best / 2, *[math.sqrt(c_best**2 - c_min**2) / 2] * 2])
    inner = np.sum((local / (radii / 2)) ** 2, axis=1) <= 1
    assert inner.mean() == pytest.approx(1 / 8, abs=0.02)


def test_interpolate_and_errors() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.25]])
    out = interpolate(path, 0.3)
    assert np.allclose(out[0], path[0]) and np.allclose(out[-1], path[-1])
    assert np.max(np.linalg.norm(np.diff(out, axis=0), axis=1)) <= 0.3 + 1e-12
    assert any(np.allclose(row, path[1]) for row in out)
    with pytest.raises(InvalidInputError):
        interpolate(path, 0.0)
    space = square_world()
    with pytest.raises(PlanningError):
        rrt_star(space, [0.5, 0.5], [0.9, 0.5])
    with pytest.raises(InvalidInputError):
        rrt_star(space, [0.1, 0.5], [0.9, 0.5], RRTStarOptions(time_limit_s=float("nan")))


def test_multiple_goals_end_at_the_cheaper_one() -> None:
    space = square_world()
    goals = np.array([[0.9, 0.5], [0.1, 0.9]])  # the second is nearer and in plain sight
    result = rrt_star(
        space,
        [0.1, 0.5],
        goals,
        RRTStarOptions(step_size=0.2, max_iterations=800, time_limit_s=None),
    )
    assert result.success and np.allclose(result.path[-1], goals[1])
    assert result.path_length == pytest.approx(0.4, rel=0.05)


class Disk:
    """A goal region: the disk of radius r about c (sampled uniformly)."""

    def __init__(self, c: list[float], r: float) -> None:
        self.c, self.r = np.array(c), r

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(q - self.c) <= self.r)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        a, u = rng.uniform(0, 2 * np.pi), np.sqrt(rng.random())
        return self.c + self.r * u * np.array([np.cos(a), np.sin(a)])


def test_goal_region_is_reached_within_its_tolerance() -> None:
    space = square_world()
    region = Disk([0.9, 0.5], 0.05)
    result = rrt_star(
        space,
        [0.1, 0.5],
        region,
        RRTStarOptions(step_size=0.2, max_iterations=2000, time_limit_s=None),
    )
    assert result.success and region.contains(result.path[-1])
    # the optimum to the disk: around the square's corner to the disk's nearest point
    corner = np.array([0.6, 0.7])
    optimum = np.hypot(0.3, 0.2) + 0.2 + np.linalg.norm(region.c - corner) - region.r
    assert optimum - 1e-9 <= result.path_length <= optimum * 1.05
