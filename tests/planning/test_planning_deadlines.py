"""Every planner and path post-processor with a time limit reads the clock before every edge
check, so it overruns the limit by one edge check at most (#22 item 2).

The Python RRT-Connect read it once per iteration: a CONNECT line (tens of steps) or a lazy
fine pass over a whole candidate path was one checker call, and a run on a heavy robot ended
30 ms past an 80 ms limit. Lines are now checked step by step and the fine pass edge by edge
(:meth:`taskspace.planning.limits.Budget.first_invalid`).

The clock is simulated: ``time.perf_counter`` advances by a fixed cost per configuration the
checker evaluates (up to the first invalid one, as a checker with early exit), so what happens
after the deadline is counted, not timed. Every checker call is a "query"; the test records
the clock readings between them.
"""

from __future__ import annotations

import importlib
import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

rrt_connect_module = importlib.import_module("taskspace.planning.rrt_connect")  # (the package
# exports the function under the module's name)

COST_S = 1e-4  # simulated seconds per checked configuration
D = 4
RESOLUTION = 0.02


def _wall_free(q: np.ndarray) -> np.ndarray:
    """[-1, 1]^4 with a wall 0.06 thick at x0 = 0 and a hole of radius 0.5 through it
    around q[1:] = (-0.5, 0, ...).

    Thinner than the coarse resolution (0.15): the coarse pass misses it, so candidate paths
    are rejected by the lazy fine pass and the fine passes are many.
    """
    in_wall = np.abs(q[:, 0]) < 0.03
    centre = np.zeros(q.shape[1] - 1)
    centre[0] = -0.5
    hole = np.linalg.norm(q[:, 1:] - centre, axis=1) < 0.5
    return np.asarray(~in_wall | hole)


class _Recorder:
    """A space whose checker drives a simulated clock and logs queries and clock readings."""

    def __init__(self, free: Callable[[np.ndarray], np.ndarray], dim: int) -> None:
        self.clock = 1000.0
        self.free = free
        self.calls: list[tuple[float, int]] = []  # (clock at the query's start, rows checked)
        self.events: list[str] = []
        self.space = ConfigurationSpace(
            -np.ones(dim),
            np.ones(dim),
            FunctionChecker(self._check),
            edge=EdgeCheckOptions(resolution=RESOLUTION),
        )

    def _check(self, q: np.ndarray) -> np.ndarray:
        ok = np.asarray(self.free(q), dtype=bool)
        bad = np.flatnonzero(~ok)
        rows = int(bad[0]) + 1 if bad.size else q.shape[0]  # early exit, as a real checker
        self.calls.append((self.clock, rows))
        self.events.append("check")
        self.clock += COST_S * rows
        return ok

    def read(self) -> float:
        self.events.append("clock")
        return self.clock

    def assert_deadline_kept(self, time_s: float, limit: float, skip: int) -> None:
        """No query after the first ``skip`` without a clock reading before it; none starts
        after the deadline; the overrun is one query at most."""
        checks = [i for i, e in enumerate(self.events) if e == "check"]
        first = checks[skip - 1] + 1 if skip else 0
        pairs = [a + b for a, b in zip(self.events[first:], self.events[first + 1 :], strict=False)]
        assert pairs.count("checkcheck") == 0
        t0 = self.clock - time_s  # nothing is checked after the planner's last reading
        deadline = t0 + limit
        during = [(t, n) for t, n in self.calls if t >= t0]
        late = [(round(t - deadline, 4), n) for t, n in during if t > deadline]
        assert late == []
        assert time_s <= limit + max(n for _, n in during) * COST_S + 1e-9


def _free_at_resolution(free: Callable[[np.ndarray], np.ndarray], path: np.ndarray) -> bool:
    """Every waypoint and every point ``k / n`` of each edge, ``n = ceil(|edge| / delta)``,
    is free (the planners' guarantee, computed with the test's own predicate)."""
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / RESOLUTION - 1e-12))
        pts = a + (np.arange(n + 1) / n)[:, None] * (b - a)
        if not np.all(free(pts)):
            return False
    return True


def _tree_nodes_free(free: Callable[[np.ndarray], np.ndarray], res: Any) -> None:
    for tree in res.trees:
        live = tree.nodes[(tree.parents >= 0) | (np.arange(len(tree.parents)) == 0)]
        assert np.all(free(live))


def _spy(monkeypatch: pytest.MonkeyPatch, name: str, seen: dict[str, int]) -> None:
    """Count the calls of rrt_connect's helper ``name`` that stopped at the deadline."""
    original = getattr(rrt_connect_module, name)

    def wrapped(*args: Any, **kwargs: Any) -> Any:
        out = original(*args, **kwargs)
        late = out == rrt_connect_module._LATE if name == "_extend" else out[-1]
        seen[name] += bool(late)
        return out

    monkeypatch.setattr(rrt_connect_module, name, wrapped)


def test_rrt_connect_python_overruns_by_one_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deadlines that fall in CONNECT lines and in lazy fine passes (both occur among these
    runs): every query starts before the deadline, the trees hold only
    free nodes, and a returned path is free (at the resolution, with the test's predicate)."""
    seen = {"_extend": 0, "_grow": 0, "_verify": 0}
    for name in seen:
        _spy(monkeypatch, name, seen)
    statuses = set()
    for seed in range(4):
        for limit in (0.003, 0.006, 0.01, 0.015, 0.02, 0.03, 0.05):
            rec = _Recorder(_wall_free, D)
            monkeypatch.setattr(time, "perf_counter", rec.read)
            start, goal = np.zeros(D), np.zeros(D)
            start[0], goal[0] = -0.9, 0.9
            start[1], goal[1] = 0.6, 0.6  # the straight line hits the wall
            opts = RRTConnectOptions(time_limit_s=limit, max_iterations=None, seed=seed)
            res = rrt_connect(rec.space, start, goal, opts)
            monkeypatch.undo()
            for name in seen:  # (undo removed the spies too)
                _spy(monkeypatch, name, seen)
            statuses.add(res.status)
            rec.assert_deadline_kept(res.time_s, limit, skip=2)  # after the two endpoints
            _tree_nodes_free(_wall_free, res)
            if res.success:
                assert _free_at_resolution(_wall_free, res.path)
            else:
                assert res.status is PlannerStatus.TIME_LIMIT
                assert res.log["stopped_by"] == "time"
    assert statuses == {PlannerStatus.SOLVED, PlannerStatus.TIME_LIMIT}
    # deadlines met inside CONNECT lines and fine passes (EXTEND reads the clock too, but
    # right after the iteration's reading unless a goal region was sampled in between)
    assert seen["_grow"] > 0 and seen["_verify"] > 0, seen


def test_rrt_connect_python_direct_lines_to_several_goals(monkeypatch: pytest.MonkeyPatch) -> None:
    """With several goals the straight start-goal lines are one edge check each, the clock
    read before each; none is checked after the deadline."""
    rec = _Recorder(_wall_free, D)
    monkeypatch.setattr(time, "perf_counter", rec.read)
    start = np.zeros(D)
    start[0], start[1] = -0.9, 0.6
    goals = np.zeros((5, D))
    goals[:, 0] = 0.9
    goals[:, 1] = 0.6 + 0.05 * np.arange(5)  # every straight line hits the wall
    limit = 8.5 * COST_S  # the six endpoint checks, then three of the lines (one check each:
    # the first point checked, the midpoint, is in the wall)
    res = rrt_connect(rec.space, start, goals, RRTConnectOptions(time_limit_s=limit, seed=0))
    assert res.status is PlannerStatus.TIME_LIMIT
    assert res.iterations == 0
    assert len(rec.calls) == 6 + 3  # no line started after the deadline
    rec.assert_deadline_kept(res.time_s, limit, skip=6)  # start and five goals


def test_rrt_reads_the_clock_before_each_goal_connection(monkeypatch: pytest.MonkeyPatch) -> None:
    """RRT: the EXTEND edge, then each goal within a step (nearest first): a clock reading
    before each edge check."""
    for seed in range(3):
        for limit in (0.05, 0.1, 0.2):
            rec = _Recorder(_wall_free, D)
            monkeypatch.setattr(time, "perf_counter", rec.read)
            start = np.zeros(D)
            start[0], start[1] = -0.9, 0.6
            goals = np.zeros((4, D))
            goals[:, 0] = 0.9
            goals[:, 1] = 0.6 - 0.02 * np.arange(4)
            opts = RRTOptions(
                time_limit_s=limit, max_iterations=None, seed=seed, goal_bias=0.3, step_size=0.4
            )
            res = rrt(rec.space, start, goals, opts)
            monkeypatch.undo()
            rec.assert_deadline_kept(res.time_s, limit, skip=5)
            _tree_nodes_free(_wall_free, res)
            assert res.status in (PlannerStatus.SOLVED, PlannerStatus.TIME_LIMIT)
            if res.success:
                assert _free_at_resolution(_wall_free, res.path)
