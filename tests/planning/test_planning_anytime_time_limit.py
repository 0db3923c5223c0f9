"""RRT* and BIT* read the clock before every edge check, so they overrun a time limit by one
edge at most (they read it once per iteration or batch: 1.06 s and 1.11 s for 1 s on Talos,
where one iteration's rewiring is hundreds of checks).

The clock is simulated: ``time.perf_counter`` advances by a fixed cost per configuration the
checker evaluates, so what happens after the deadline is counted, not timed. The planner's
start time is the last clock reading minus its reported ``time_s`` (nothing is checked after
its last reading).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

COST_S = 1e-3  # simulated seconds per checked configuration
D = 20


def _space(clock: list[float], calls: list[list[float]], events: list[str]) -> ConfigurationSpace:
    """[-1, 1]^20 around a ball of radius 0.5; every check costs COST_S of the clock.

    ``calls`` gets [clock, checks] of every query: a whole edge check (the checker calls of
    ``motion_valid``, which sends an edge in batches of growing size) or a checker call;
    ``events`` gets "check" for each query (and the test's clock adds "clock" per reading).
    """
    edge = [False]

    def free(q: np.ndarray) -> np.ndarray:
        if not edge[0]:
            calls.append([clock[0], q.shape[0]])
            events.append("check")
        clock[0] += COST_S * q.shape[0]
        return np.asarray(np.linalg.norm(q, axis=1) > 0.5)

    space = ConfigurationSpace(
        -np.ones(D), np.ones(D), FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.01)
    )
    motion_valid = space.motion_valid

    def edge_check(*args: Any, **kwargs: Any) -> bool:
        call = [clock[0], 0]
        calls.append(call)
        events.append("check")
        edge[0] = True
        try:
            return bool(motion_valid(*args, **kwargs))
        finally:
            edge[0] = False
            call[1] = round((clock[0] - call[0]) / COST_S)

    space.motion_valid = edge_check  # type: ignore[method-assign]
    return space


PLANNERS: dict[str, Callable[[ConfigurationSpace, Any, Any, float, int], Any]] = {
    "rrt_star": lambda space, s, g, limit, seed: rrt_star(
        space,
        s,
        g,
        RRTStarOptions(
            time_limit_s=limit, max_iterations=None, seed=seed, first_solution="rrt_star"
        ),
    ),
    "bit_star": lambda space, s, g, limit, seed: bit_star(
        space, s, g, BITStarOptions(time_limit_s=limit, max_iterations=None, seed=seed)
    ),
}


@pytest.mark.parametrize("planner", sorted(PLANNERS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_check_starts_after_the_deadline(
    monkeypatch: pytest.MonkeyPatch, planner: str, seed: int
) -> None:
    clock = [1000.0]
    calls: list[list[float]] = []
    events: list[str] = []
    space = _space(clock, calls, events)

    def read() -> float:
        events.append("clock")
        return clock[0]

    monkeypatch.setattr(time, "perf_counter", read)
    start = np.zeros(D)
    start[0] = -0.9
    limit = 0.5
    res = PLANNERS[planner](space, start, -start, limit, seed)
    assert res.log["stopped_by"] == "time"
    # the clock is read between any two queries (edge checks, checker calls) after the
    # endpoint checks of start and goal (the first two queries)
    first = [i for i, e in enumerate(events) if e == "check"][1] + 1
    pairs = [a + b for a, b in zip(events[first:], events[first + 1 :], strict=False)]
    assert pairs.count("checkcheck") == 0
    t0 = clock[0] - res.time_s
    deadline = t0 + limit
    during = [(t, n) for t, n in calls if t >= t0]
    assert sum(n for _, n in during) * COST_S >= limit  # the checks drove the clock
    late = [(round(t - deadline, 4), n) for t, n in during if t > deadline]
    assert late == []  # every query started before the deadline
    # so the overrun is at most one query: an edge of the 20-D box at the resolution
    assert res.time_s <= limit + max(n for _, n in during) * COST_S + 1e-9
