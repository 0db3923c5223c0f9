"""One status for a goal region none of whose samples is ever valid, on every planner.

Every planner with a budget keeps drawing the region's samples within it; no number of
failed draws proves the region empty, so the run ends because the budget ran out:
``ITERATION_LIMIT`` or ``TIME_LIMIT`` (whichever stopped it), ``log["goal_states"] == 0``
saying that no goal configuration was found. ``NO_PATH`` stays the answer of a query on a
given roadmap (``prm_query``, ``lazy_prm_query``): that roadmap does not reach the region.
Before, RRT and RRT-Connect said ``NO_PATH`` after spending their budget, the others the limit.

The regions: one whose samples all lie inside an obstacle (checked by hand: the disc), one
whose sampler never returns a configuration.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from taskspace.planning import (
    PRMOptions,
    build_lazy_prm,
    build_prm,
    lazy_prm_query,
    prm_query,
)
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.planner_result import PlannerStatus
from tests.planning._planning_worlds import PLANNERS

CENTER = np.array([0.8, 0.8])
START = [0.1, 0.1]


def _space() -> ConfigurationSpace:
    """The unit square; the disc of radius 0.1 around (0.8, 0.8) collides."""
    return ConfigurationSpace(
        [0.0, 0.0],
        [1.0, 1.0],
        FunctionChecker(lambda q: np.linalg.norm(q - CENTER, axis=1) > 0.1),
    )


class _InsideTheObstacle:
    """Samples within 0.03 of the disc's centre: every one collides."""

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(np.asarray(q) - CENTER) < 0.05)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        return CENTER + rng.uniform(-0.03, 0.03, 2)


class _NeverSampled:
    def contains(self, q: np.ndarray) -> bool:
        return False

    def sample(self, rng: np.random.Generator) -> None:
        return None


REGIONS = {"in_obstacle": _InsideTheObstacle, "never_sampled": _NeverSampled}


def _run(name: str, region: Any, **limits: Any) -> Any:
    planner, options = PLANNERS[name]
    result = planner(_space(), START, region, options(seed=1, **limits))
    return result[0] if isinstance(result, tuple) else result


@pytest.mark.parametrize("region", REGIONS)
@pytest.mark.parametrize("name", PLANNERS)
def test_iterations_spent_without_a_goal_state_is_the_iteration_limit(
    name: str, region: str
) -> None:
    result = _run(name, REGIONS[region](), max_iterations=150, time_limit_s=None)
    assert not result.success
    assert result.status is PlannerStatus.ITERATION_LIMIT
    assert result.log["goal_states"] == 0.0
    assert result.path.shape == (0, 2)


@pytest.mark.parametrize("region", REGIONS)
@pytest.mark.parametrize("name", [n for n in PLANNERS if n != "prm"])  # prm needs a size
def test_time_spent_without_a_goal_state_is_the_time_limit(name: str, region: str) -> None:
    result = _run(name, REGIONS[region](), max_iterations=None, time_limit_s=0.05)
    assert not result.success
    assert result.status is PlannerStatus.TIME_LIMIT
    assert result.log["goal_states"] == 0.0
    assert result.time_s >= 0.05


@pytest.mark.parametrize("region", REGIONS)
def test_a_query_on_a_given_roadmap_says_no_path(region: str) -> None:
    space = _space()
    options = PRMOptions(max_iterations=150, time_limit_s=None, seed=1)
    roadmap = build_prm(space, options, rng=np.random.default_rng(1))
    lazy = build_lazy_prm(space, options, rng=np.random.default_rng(1))
    for result in (
        prm_query(space, roadmap, START, REGIONS[region](), options),
        lazy_prm_query(space, lazy, START, REGIONS[region](), options),
    ):
        assert not result.success
        assert result.status is PlannerStatus.NO_PATH
        assert result.log["goal_states"] == 0.0


class _SamplesOutside:
    """Contains the disc of radius 0.05 around (0.5, 0.8); its sampler returns (0.5, 0.6),
    a free configuration outside it (a user's region whose sampler is wrong)."""

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(np.asarray(q) - [0.5, 0.8]) < 0.05)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        return np.array([0.5, 0.6])


@pytest.mark.parametrize("name", PLANNERS)
def test_a_sample_the_region_does_not_contain_is_never_a_goal(name: str) -> None:
    """A solved path ends inside the region, checked by hand (rrt_star, bit_star, prm_star and
    lazy_prm_star returned paths ending at the uncontained sample (0.5, 0.6))."""
    result = _run(name, _SamplesOutside(), max_iterations=300, time_limit_s=None)
    if result.success:
        assert np.linalg.norm(result.path[-1] - [0.5, 0.8]) < 0.05
    else:
        assert result.status is PlannerStatus.ITERATION_LIMIT
