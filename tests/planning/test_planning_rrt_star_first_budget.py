"""RRT* / informed RRT* started by RRT-Connect (``first_solution="rrt_connect"``) keep the
time limit: RRT-Connect gets exactly the time left, is not called without time left, and
RRT* makes no check after RRT-Connect returned past the deadline.

The clock is simulated (``time.perf_counter`` advances by a fixed cost per checked
configuration), so budgets and late checks are counted, not timed.
"""

from __future__ import annotations

import importlib
import time
from typing import Any

import numpy as np
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

# the modules (the package's names rrt_connect and rrt_star are the functions)
rrt_connect_module = importlib.import_module("taskspace.planning.rrt_connect")
rrt_star_module = importlib.import_module("taskspace.planning.rrt_star")

COST_S = 1e-3  # simulated seconds per checked configuration
D = 6


class _World:
    """A simulated clock, the checks made at each reading, and the RRT-Connect calls."""

    def __init__(self) -> None:
        self.clock = 1000.0
        self.checks: list[tuple[float, int]] = []  # (clock at the call, configurations)
        self.connect_calls: list[tuple[float, Any]] = []  # (clock, time_limit_s passed)
        self.connect_done: list[float] = []  # clock when RRT-Connect returned

    def read(self) -> float:
        return self.clock

    def space(self) -> ConfigurationSpace:
        def free(q: np.ndarray) -> np.ndarray:
            self.checks.append((self.clock, q.shape[0]))
            self.clock += COST_S * q.shape[0]
            return np.asarray(np.linalg.norm(q, axis=1) > 0.5)

        return ConfigurationSpace(
            -np.ones(D), np.ones(D), FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.05)
        )


def _patch(monkeypatch: pytest.MonkeyPatch, world: _World) -> None:
    real = rrt_connect_module.rrt_connect

    def recording(*args: Any, **kwargs: Any) -> Any:
        options = args[3] if len(args) > 3 else kwargs["options"]
        world.connect_calls.append((world.clock, options.time_limit_s))
        try:
            return real(*args, **kwargs)
        finally:
            world.connect_done.append(world.clock)

    monkeypatch.setattr(time, "perf_counter", world.read)
    monkeypatch.setattr(rrt_connect_module, "rrt_connect", recording)


def _ends() -> tuple[np.ndarray, np.ndarray]:
    start = np.zeros(D)
    start[0] = -0.9
    return start, -start


@pytest.mark.parametrize("informed", [True, False])
def test_rrt_connect_gets_exactly_the_time_left(
    monkeypatch: pytest.MonkeyPatch, informed: bool
) -> None:
    world = _World()
    _patch(monkeypatch, world)
    space = world.space()
    start, goal = _ends()
    limit = 50.0  # simulated seconds: RRT-Connect solves well within it
    t_call = [0.0]
    real_first_goal = rrt_star_module._first_goal

    def first_goal(*args: Any) -> int:  # the planner's clock before RRT-Connect: +3 s
        world.clock += 3.0
        t_call[0] = world.clock
        return real_first_goal(*args)

    monkeypatch.setattr(rrt_star_module, "_first_goal", first_goal)
    t0 = world.clock
    res = rrt_star(
        space,
        start,
        goal,
        RRTStarOptions(time_limit_s=limit, max_iterations=60, seed=3, informed=informed),
    )
    assert res.success and res.log["first_solution_by"] == "rrt_connect"
    assert len(world.connect_calls) == 1
    clock_at_call, passed = world.connect_calls[0]
    assert clock_at_call == t_call[0]  # nothing checked between the reading and the call
    # the planner's clock starts after the endpoint checks of start and goal (one each)
    assert [n for t, n in world.checks if t < clock_at_call] == [1, 1]
    started = t0 + 2 * COST_S
    assert passed == pytest.approx(started + limit - clock_at_call, abs=1e-9)
    assert passed < limit - 3.0 + 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_check_after_rrt_connect_returns_late(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    world = _World()
    _patch(monkeypatch, world)
    space = world.space()
    start, goal = _ends()
    limit = 0.08  # 80 checks: RRT-Connect runs out of time
    res = rrt_star(
        space, start, goal, RRTStarOptions(time_limit_s=limit, max_iterations=None, seed=seed)
    )
    assert len(world.connect_calls) == 1 and len(world.connect_done) == 1
    returned = world.connect_done[0]
    t0 = world.clock - res.time_s
    assert world.connect_calls[0] == (pytest.approx(t0), pytest.approx(limit))  # all of it
    after = [(t, n) for t, n in world.checks if t >= returned]
    if returned > world.connect_calls[0][0] + world.connect_calls[0][1]:  # returned late
        assert after == []  # RRT* checked nothing after it
        assert res.log["stopped_by"] == "time"
    assert all(t <= t0 + limit for t, _ in after)  # RRT* starts no check past the deadline


def test_rrt_connect_not_called_without_time_left(monkeypatch: pytest.MonkeyPatch) -> None:
    world = _World()
    _patch(monkeypatch, world)
    space = world.space()
    start, goal = _ends()
    real_first_goal = rrt_star_module._first_goal

    def slow_first_goal(*args: Any) -> int:  # the budget is spent before RRT-Connect
        world.clock += 1.0
        return real_first_goal(*args)

    monkeypatch.setattr(rrt_star_module, "_first_goal", slow_first_goal)
    res = rrt_star(space, start, goal, RRTStarOptions(time_limit_s=0.5, max_iterations=None))
    assert world.connect_calls == []
    assert not res.success and res.status is PlannerStatus.TIME_LIMIT
    assert res.log["stopped_by"] == "time"
    assert len(world.checks) == 2  # the endpoint checks of start and goal only
