"""The edge cases of the limits follow one rule for every planner (issue #22 audit, stop 23).

``time_limit_s=0`` gave ``SOLVED``, ``TIME_LIMIT`` or ``ITERATION_LIMIT`` depending on the
planner; ``max_iterations=0`` was refused by PRM, and some planners tried the straight line
with it while others did not. The rule (:mod:`taskspace.planning.limits`): a start equal to
the goal is ``SOLVED`` whatever the limits; then the clock (``time_limit_s=0``:
``TIME_LIMIT`` before any check); then, with ``max_iterations=0``, only the straight line
(``SOLVED`` with ``[start, goal]`` when free, else ``ITERATION_LIMIT``).

Expected answers are analytic: the unit square with a wall ``|x - 0.5| < 0.03, y < 0.8``;
the line at ``y = 0.9`` is free, the one at ``y = 0.1`` crosses the wall. The clock is
simulated (each reading advances it 1 us), so ``time_limit_s=0`` has passed at the first
reading after the start on any machine.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from taskspace.model import Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import lazy_prm
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.prm import PRMOptions, prm
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

RES = 0.01

PLANNERS: dict[str, tuple[type, Callable[..., Any]]] = {
    "rrt": (RRTOptions, rrt),
    "rrt_connect": (RRTConnectOptions, rrt_connect),
    "rrt_star": (RRTStarOptions, rrt_star),
    "rrt_star_own_first": (
        RRTStarOptions,
        lambda s, a, b, o: rrt_star(s, a, b, dataclasses.replace(o, first_solution="rrt_star")),
    ),
    "bit_star": (BITStarOptions, bit_star),
    "prm_star": (PRMStarOptions, prm_star),
    "lazy_prm_star": (PRMStarOptions, lazy_prm_star),
    "prm": (PRMOptions, prm),
    "lazy_prm": (PRMOptions, lazy_prm),
}


class _Disk:
    """A goal region: the disk of radius 0.05 around (0.1, 0.1) (it holds the start)."""

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(np.asarray(q) - [0.1, 0.1]) <= 0.05)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        r, a = 0.05 * math.sqrt(rng.random()), 2 * math.pi * rng.random()
        return np.array([0.1 + r * math.cos(a), 0.1 + r * math.sin(a)])


CASES: dict[str, tuple[list[float], Any]] = {  # start, goal
    "free": ([0.1, 0.9], [0.9, 0.9]),
    "blocked": ([0.1, 0.1], [0.9, 0.1]),
    "same": ([0.1, 0.1], [0.1, 0.1]),
    "in_region": ([0.1, 0.1], None),  # the start inside the goal region
}

LIMITS = {  # (max_iterations, time_limit_s)
    "no_iterations": (0, 1.0),
    "no_time": (100, 0.0),
    "neither": (0, 0.0),
}


def _wall(q: np.ndarray) -> np.ndarray:
    return np.asarray(~((np.abs(q[:, 0] - 0.5) < 0.03) & (q[:, 1] < 0.8)))


def _expected(case: str, limits: str) -> PlannerStatus:
    """The rule, written out: trivial answer, then the clock, then the straight line."""
    if case in ("same", "in_region"):
        return PlannerStatus.SOLVED
    if LIMITS[limits][1] == 0.0:
        return PlannerStatus.TIME_LIMIT
    return PlannerStatus.SOLVED if case == "free" else PlannerStatus.ITERATION_LIMIT


@pytest.fixture
def slow_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = [50.0]

    def read() -> float:
        clock[0] += 1e-6
        return clock[0]

    monkeypatch.setattr(time, "perf_counter", read)


def _result(out: Any) -> PlannerResult:
    return out[0] if isinstance(out, tuple) else out


@pytest.mark.usefixtures("slow_clock")
@pytest.mark.parametrize("limits", list(LIMITS))
@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("name", list(PLANNERS))
def test_one_rule_for_zero_limits(name: str, case: str, limits: str) -> None:
    space = ConfigurationSpace(
        np.zeros(2), np.ones(2), FunctionChecker(_wall), edge=EdgeCheckOptions(resolution=RES)
    )
    start = np.array(CASES[case][0])
    goal: Any = _Disk() if case == "in_region" else np.array(CASES[case][1])
    cap, limit = LIMITS[limits]
    cls, plan = PLANNERS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no deprecated path on the way
        result = _result(plan(space, start, goal, cls(max_iterations=cap, time_limit_s=limit)))
    expected = _expected(case, limits)
    assert result.status is expected, (name, case, limits, result.status)
    assert result.success == (expected is PlannerStatus.SOLVED)
    assert result.iterations == 0
    if case == "in_region":  # a one-point path
        np.testing.assert_array_equal(result.path, start[None, :])
        assert result.path_length == 0.0
    elif result.success:  # the straight line (a zero-length one for "same")
        np.testing.assert_array_equal(result.path, np.stack([start, goal]))
        assert result.path_length == pytest.approx(float(np.linalg.norm(goal - start)))
        if result.cost is not None:
            assert result.cost == pytest.approx(result.path_length)
    else:
        assert result.path.shape == (0, 2) and math.isinf(result.path_length)
    # nothing but the endpoints (and the line when the clock allows it) was checked
    if case == "in_region":  # and the region's first samples (20 at most) for some planners
        allowed = 2 + 20
    elif expected is PlannerStatus.TIME_LIMIT or case == "same":
        allowed = 2
    else:
        allowed = 2 + math.ceil(float(np.linalg.norm(goal - start)) / RES) + 1
    assert result.collision_checks <= allowed
    stopped_by = {
        PlannerStatus.SOLVED: ("first solution", "optimal"),  # the line is the optimum
        PlannerStatus.TIME_LIMIT: ("time",),
        PlannerStatus.ITERATION_LIMIT: ("iterations",),
    }[expected]
    assert result.log["stopped_by"] in stopped_by


@pytest.mark.parametrize("limits", list(LIMITS))
@pytest.mark.parametrize("case", ["free", "same"])
def test_the_compiled_rrt_connect_follows_the_rule(case: str, limits: str) -> None:
    robot = Robot.load("ur5")
    space = ConfigurationSpace.from_robot(robot)
    start = robot.q_default.copy()
    goal = start.copy()
    if case == "free":
        goal[0] += 0.5
    assert space.motion_valid(start, goal)
    cap, limit = LIMITS[limits]
    result = rrt_connect(
        space, start, goal, RRTConnectOptions(max_iterations=cap, time_limit_s=limit)
    )
    assert result.log.get("native") == 1.0
    assert result.status is _expected(case, limits)
    if result.success:
        np.testing.assert_array_equal(result.path, np.stack([start, goal]))
