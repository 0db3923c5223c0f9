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

from taskspace.model import Obstacle, Robot
from taskspace.planning.car import CarModel
from taskspace.planning.certify import certify_path, certify_planned
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.kinodynamic_rrt import (
    KinodynamicRRTOptions,
    RRTStatus,
    kinodynamic_rrt,
    parking_lot,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.shortcut import ShortcutOptions, _check_input, shortcut_path
from taskspace.planning.smoothing import SmoothingOptions, smooth_bspline

rrt_connect_module = importlib.import_module("taskspace.planning.rrt_connect")  # (the package
# exports the function under the module's name)

COST_S = 1e-4  # simulated seconds per checked configuration
D = 4
RESOLUTION = 0.02
MAX_ROWS = 32  # EdgeCheckOptions.max_batch; a step of 0.5 has 26 points at the resolution


def _wall_free(q: np.ndarray) -> np.ndarray:
    """[-1, 1]^4 with a wall 0.06 thick at x0 = 0 and a hole of radius 0.5 through it
    around q[1:] = (-0.5, 0, ...).

    Thinner than the default coarse resolution (0.15): the coarse pass misses it, so candidate paths
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

    def assert_deadline_kept(
        self, time_s: float, limit: float, skip: int, *, t0: float | None = None, tail: int = 0
    ) -> None:
        """No query after the first ``skip`` (and before the last ``tail``) without a clock
        reading before it; none starts after the deadline ``t0 + limit`` (``t0``: the clock at
        the start, by default the last reading minus ``time_s``); the overrun is one query at
        most."""
        checks = [i for i, e in enumerate(self.events) if e == "check"]
        first = checks[skip - 1] + 1 if skip else 0
        last = checks[-tail] if tail else len(self.events)
        events = self.events[first:last]
        pairs = [a + b for a, b in itertools.pairwise(events)]
        assert pairs.count("checkcheck") == 0
        if t0 is None:
            t0 = self.clock - time_s  # nothing is checked after the planner's last reading
        deadline = t0 + limit
        calls = self.calls[: len(self.calls) - tail]
        during = [(t, n) for t, n in calls if t >= t0]
        late = [(round(t - deadline, 4), n) for t, n in during if t > deadline]
        assert late == []
        # every query is one step, one edge's fine points or one batch of an edge: at most
        # MAX_ROWS rows (a whole CONNECT line or fine pass in one call is more)
        assert max(n for _, n in calls[skip:]) <= MAX_ROWS
        if not tail:  # (the clock's last reading is the planner's end)
            assert self.clock <= deadline + MAX_ROWS * COST_S + 1e-9


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
    for seed in range(6):
        for limit in (0.003, 0.006, 0.01, 0.015, 0.02, 0.03, 0.05):
            rec = _Recorder(_wall_free, D)
            monkeypatch.setattr(time, "perf_counter", rec.read)
            start, goal = np.zeros(D), np.zeros(D)
            start[0], goal[0] = -0.9, 0.9
            start[1], goal[1] = 0.6, 0.6  # the straight line hits the wall
            # lazy (default resolutions: many fine passes) or eager with short steps (every
            # step's 13 points checked at once: long CONNECT lines)
            eager = seed % 2 == 1
            opts = RRTConnectOptions(
                time_limit_s=limit,
                max_iterations=None,
                seed=seed,
                step_size=0.25 if eager else 0.5,
                coarse_resolution=None if eager else 0.15,
            )
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


def _detour(n: int) -> np.ndarray:
    """A free path through the wall's hole with ``n`` waypoints per leg, zigzagging."""
    a, hole, b = np.zeros(D), np.zeros(D), np.zeros(D)
    a[0], a[1] = -0.9, 0.6
    hole[1] = -0.5
    b[0], b[1] = 0.9, 0.6
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    legs = [a + t * (hole - a), hole + t[1:] * (b - hole)]
    path = np.vstack(legs)
    zig = np.zeros_like(path)
    zig[1:-1, 2] = 0.08 * (-1.0) ** np.arange(path.shape[0] - 2)
    path = path + zig
    assert _free_at_resolution(_wall_free, path)
    return path


def _queries(fn: Callable[[ConfigurationSpace], Any]) -> int:
    """Checker calls of ``fn`` on a fresh recording space (deterministic checks)."""
    rec = _Recorder(_wall_free, D)
    fn(rec.space)
    return len(rec.calls)


@pytest.mark.parametrize("greedy", [True, False])
def test_shortcut_keeps_its_limit_and_returns_a_free_path(
    monkeypatch: pytest.MonkeyPatch, greedy: bool
) -> None:
    """The greedy pass and the random shortcuts read the clock before every checker call;
    whatever the limit cuts, the result is free at the resolution and no longer."""
    path = _detour(12)
    skip = _queries(lambda space: _check_input(space, path))
    cut = 0
    for limit in (0.0005, 0.001, 0.002, 0.004, 0.008, 0.02):
        rec = _Recorder(_wall_free, D)
        monkeypatch.setattr(time, "perf_counter", rec.read)
        opts = ShortcutOptions(time_limit_s=limit, max_iterations=200, greedy=greedy, seed=1)
        res = shortcut_path(rec.space, path, opts)
        monkeypatch.undo()
        t0 = 1000.0 + COST_S * sum(n for _, n in rec.calls[:skip])  # after the input check
        rec.assert_deadline_kept(res.time_s, limit, skip, t0=t0)
        cut += rec.clock > t0 + limit
        assert np.array_equal(res.path[0], path[0]) and np.array_equal(res.path[-1], path[-1])
        assert _free_at_resolution(_wall_free, res.path)
        assert res.length_after <= res.length_before + 1e-12
    assert cut >= 3  # the limit stopped most runs


def test_smoothing_keeps_its_limit_and_returns_a_free_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """B-spline passes read the clock before every checker call (the new point, each new
    segment); the checks of the input and of the result are not counted."""
    path = _detour(4)
    skip = _queries(lambda space: _check_input(space, path, "smooth_bspline"))
    cut = 0
    for limit in (0.0005, 0.001, 0.002, 0.005, 0.01, 0.03):
        rec = _Recorder(_wall_free, D)
        monkeypatch.setattr(time, "perf_counter", rec.read)
        opts = SmoothingOptions(time_limit_s=limit, max_iterations=None, max_step=0.1)
        res = smooth_bspline(rec.space, path, opts)
        monkeypatch.undo()
        tail = _queries(lambda space, p=res.path: space.path_valid(p))  # the final guard
        t0 = 1000.0 + COST_S * sum(n for _, n in rec.calls[:skip])
        rec.assert_deadline_kept(res.time_s, limit, skip, t0=t0, tail=tail)
        end = rec.calls[-tail - 1] if len(rec.calls) > skip + tail else (t0, 0)
        cut += end[0] + end[1] * COST_S > t0 + limit
        assert _free_at_resolution(_wall_free, res.path)
        assert res.length_after <= res.length_before + 1e-12
    assert cut >= 3


def test_kinodynamic_rrt_reads_the_clock_before_the_goal_curve(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The extension and the curve to the goal are one check each, the clock read before
    each; a node whose edge was checked stays when the time runs out before the goal curve."""
    world, start, goal = parking_lot(lane_width=12.0)
    events: list[str] = []
    calls: list[tuple[float, int]] = []
    clock = [1000.0]
    poses_free = CarModel.poses_free

    def counted(self: CarModel, w: Any, poses: Any) -> Any:
        out = poses_free(self, w, poses)
        rows = np.atleast_2d(np.asarray(poses)).shape[0]
        calls.append((clock[0], rows))
        events.append("check")
        clock[0] += COST_S * rows
        return out

    def read() -> float:
        events.append("clock")
        return clock[0]

    statuses = set()
    for limit in np.linspace(0.002, 0.03, 29).tolist():  # (the old code started a goal
        for seed in range(3):  # curve's check after the deadline in 3 of these 87 runs)
            events.clear()
            calls.clear()
            clock[0] = 1000.0
            monkeypatch.setattr(CarModel, "poses_free", counted)
            monkeypatch.setattr(time, "perf_counter", read)
            opts = KinodynamicRRTOptions(
                steering="reeds_shepp", time_limit_s=limit, max_iterations=None, seed=seed
            )
            res = kinodynamic_rrt(CarModel(), world, start, goal, options=opts)
            monkeypatch.undo()
            statuses.add(res.status)
            checks = [i for i, e in enumerate(events) if e == "check"]
            tail = events[checks[1] + 1 :]  # after the start and goal checks
            pairs = [a + b for a, b in itertools.pairwise(tail)]
            assert pairs.count("checkcheck") == 0
            assert all(t - 1000.0 <= limit + 1e-12 for t, _ in calls)  # none after the deadline
            if res.status is RRTStatus.REACHED:
                assert np.all(CarModel().poses_free(world, res.path))
    assert statuses == {RRTStatus.REACHED, RRTStatus.TIME_LIMIT}


def test_certification_reads_the_clock_before_each_distance_query(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """certify_path with a deadline starts no distance query after it (``timed_out``, not
    certified); certify_planned then reports TIME_LIMIT, not a certified or uncertified path."""
    import pinocchio as pin

    import taskspace.planning.certify as certify_module

    # the Python certifier (its distance queries are Pinocchio calls this test can count; the
    # compiled certifier's deadline is tested in test_planning_certify_native.py)
    monkeypatch.setattr(certify_module, "native_certifier", lambda *args, **kwargs: None)
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.box("block", [0.1, 0.4, 0.3], [0.45, 0.0, 0.35]))
    q0 = robot.q_default.copy()
    path = np.array([q0, q0 + np.r_[0.4, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0][: robot.nq]])
    full = certify_path(robot, path)  # the reference: real clock, no deadline
    assert full.certified and not full.timed_out and full.distance_queries >= 4
    clock = [1000.0]
    starts: list[float] = []
    compute = pin.computeDistances

    def counted(*args: Any) -> Any:
        starts.append(clock[0])
        clock[0] += COST_S
        return compute(*args)

    monkeypatch.setattr(pin, "computeDistances", counted)
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    for k in range(full.distance_queries + 1):
        clock[0], starts[:] = 1000.0, []
        deadline = 1000.0 + (k - 0.5) * COST_S  # room for k queries
        cert = certify_path(robot, path, deadline=deadline)
        assert all(t <= deadline for t in starts)
        assert len(starts) == min(k, full.distance_queries)
        if k < full.distance_queries:
            assert cert.timed_out and not cert.certified
        else:
            assert cert.certified and not cert.timed_out
    space = ConfigurationSpace.from_robot(robot)

    def plan(attempt: int, left: float) -> PlannerResult:
        clock[0] += 0.5 * COST_S  # the planner's own work
        return PlannerResult(
            success=True,
            status=PlannerStatus.SOLVED,
            path=path.copy(),
            path_length=float(np.linalg.norm(path[1] - path[0])),
            iterations=1,
            collision_checks=0,
            edge_checks=0,
            time_s=0.0,
            trees=[],
            log={"stopped_by": "first solution"},
        )

    clock[0], starts[:] = 1000.0, []
    limit = 2.2 * COST_S  # two queries after the planner's half query
    res = certify_planned(space, plan, time_limit_s=limit, retries=2)
    assert not res.success and res.status is PlannerStatus.TIME_LIMIT
    assert res.log["stopped_by"] == "time" and res.log["certified"] == 0.0
    assert len(starts) == 2 and all(t <= 1000.0 + limit for t in starts)
    clock[0], starts[:] = 1000.0, []
    res = certify_planned(space, plan, time_limit_s=1.0, retries=2)
    assert res.success and res.log["certified"] == 1.0


def test_budget_first_invalid_against_enumeration(monkeypatch: pytest.MonkeyPatch) -> None:
    """Budget.first_invalid: (first invalid row, rows checked free before it) or, out of
    time, (-1, the start of the first group not checked); with no limit one call. Compared
    with a row-by-row enumeration for every invalid row, group layout and deadline."""
    from taskspace.planning.limits import Budget

    clock = [0.0]
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    rng = np.random.default_rng(0)
    for _ in range(300):
        n = int(rng.integers(1, 12))
        bounds = sorted({*rng.integers(0, n + 1, size=3).tolist(), n})
        invalid = int(rng.integers(-1, n))
        budget_rows = int(rng.integers(0, n + 2))  # rows the clock allows before the deadline
        limit = math.inf if rng.random() < 0.2 else budget_rows - 0.5
        clock[0] = 0.0
        calls: list[int] = []

        def check(rows: np.ndarray, calls: list[int] = calls, invalid: int = invalid) -> int:
            calls.append(rows.size)
            hit = [i for i, r in enumerate(rows.tolist()) if r == invalid]
            clock[0] += hit[0] + 1 if hit else rows.size
            return hit[0] if hit else -1

        got = Budget(10, limit, 0.0).first_invalid(check, np.arange(n), bounds)
        # the reference: walk the groups row by row
        lo, want = 0, (-1, n)
        for hi in bounds:
            if hi <= lo:
                continue
            if lo > limit:  # (one row costs one unit of the clock)
                want = (-1, lo)
                break
            if lo <= invalid < hi:
                want = (invalid, invalid)
                break
            lo = hi
        assert got == want, (n, bounds, invalid, limit)
        if math.isinf(limit):
            assert len(calls) == 1
