"""RRT-Connect with a goal region none of whose first 20 samples is valid.

Its docstring promises a region's valid samples "20 drawn first, one more every 64
iterations": when none of the first 20 was valid it returned NO_PATH at once, with 0
iterations, though RRT, RRT*, BIT* and the PRMs* solve the same problem. It now draws one
more sample per iteration until one is valid, under the limits; a region it can never sample
ends with the limit spent (ITERATION_LIMIT or TIME_LIMIT, as every planner says). The paths
are checked every 1e-3 against the boxes themselves.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from tests.planning._planning_worlds import free_densely, wall_space

START = [1.0, 2.0]  # the straight line to the region crosses the wall


class _StingyDisc:
    """The disc of radius 0.2 around (9, 2); its sampler fails its first ``fails`` calls."""

    def __init__(self, fails: int) -> None:
        self.calls = 0
        self.fails = fails

    def contains(self, q: np.ndarray) -> bool:
        return float(np.hypot(q[0] - 9.0, q[1] - 2.0)) <= 0.2

    def sample(self, rng: np.random.Generator) -> np.ndarray | None:
        self.calls += 1
        if self.calls <= self.fails:
            return None
        angle, r = rng.uniform(0.0, 2 * np.pi), 0.2 * np.sqrt(rng.uniform())
        return np.array([9.0 + r * np.cos(angle), 2.0 + r * np.sin(angle)])


@pytest.mark.parametrize("fails", [20, 25, 300])
def test_a_region_valid_only_after_its_first_samples_is_reached(fails: int) -> None:
    region = _StingyDisc(fails)
    result = rrt_connect(
        wall_space(), START, region, RRTConnectOptions(max_iterations=5000, time_limit_s=None)
    )
    assert result.status is PlannerStatus.SOLVED
    assert np.array_equal(result.path[0], START)
    assert region.contains(result.path[-1])
    assert free_densely(result.path)
    assert result.iterations > fails - 20  # the draws after the first 20 count


def test_a_region_never_sampled_is_the_iteration_limit() -> None:
    region = _StingyDisc(10**9)
    result = rrt_connect(
        wall_space(), START, region, RRTConnectOptions(max_iterations=50, time_limit_s=None)
    )
    assert result.status is PlannerStatus.ITERATION_LIMIT
    assert result.iterations == 50 and region.calls == 20 + 50
    assert result.path.shape == (0, 2)


def test_a_region_never_sampled_is_the_time_limit() -> None:
    region = _StingyDisc(10**9)
    result = rrt_connect(
        wall_space(), START, region, RRTConnectOptions(max_iterations=None, time_limit_s=0.05)
    )
    assert result.status is PlannerStatus.TIME_LIMIT
    assert result.time_s >= 0.05 and region.calls > 20  # it went on drawing until the limit
    assert result.path.shape == (0, 2)
