"""The one limit convention of every sampling-based planner of taskspace.

Every planner's ``Options`` has ``max_iterations`` and ``time_limit_s``:

* ``max_iterations``: an integer >= 0, or ``None`` for no cap (then the time limit must be
  finite). One iteration is one sample for every planner (RRT, RRT-Connect, RRT*, PRM, Lazy
  PRM, PRM*, BIT*). A roadmap built at once (:func:`~taskspace.planning.build_prm`,
  :func:`~taskspace.planning.prm`, :func:`~taskspace.planning.build_lazy_prm`) has
  ``max_iterations`` nodes, so it needs an integer;
* ``time_limit_s``: a wall-clock budget [s], ``None`` or ``math.inf`` for none (then the
  iteration cap must be an integer); NaN, negative numbers and bools are refused. ``None``
  means "no time limit" for every planner: :func:`~taskspace.planning.lazy_prm` given
  ``PRMOptions(time_limit_s=None)`` ran for 1 s, and now has no time limit (a
  ``DeprecationWarning`` says so; with ``max_iterations=None`` too it keeps the 1 s, warned,
  rather than being refused). The defaults differ by planner (1 s for most, 5 s for RRT,
  none for PRM, whose roadmap size is its cap); :func:`~taskspace.planning.lazy_prm` without
  options has no sample cap and 1 s.

Deprecated names (still accepted, with a ``DeprecationWarning``): ``PRMOptions.n_samples``
(``max_iterations`` for PRM; the samples per growth round, now ``PRMOptions.batch_size``,
for Lazy PRM) and :func:`~taskspace.planning.lazy_prm`'s keyword ``max_rounds`` (growth rounds:
a cap of ``max_rounds * batch_size`` samples). Lazy PRM also takes ``time_limit_s`` as a
keyword (given twice, they must agree).

Edge cases: one rule for every planner (:func:`edge_case`), in this order:

1. the options and the endpoints are validated (bad ones raise, whatever the limits);
2. trivial answers need no limit: a start equal to a goal (path ``[start, goal]``) or inside
   a goal region (path ``[start]``) is ``SOLVED`` even with ``max_iterations=0`` or
   ``time_limit_s=0``;
3. the clock is read next: a deadline already passed (``time_limit_s=0``) stops the planner
   before any check, ``TIME_LIMIT`` (also with ``max_iterations=0``: the clock comes first);
4. ``max_iterations=0`` allows no sample: the planner checks the straight line from the start
   to each goal (nearest first, under the clock) and returns the first free one (``SOLVED``,
   the anytime planners too), else ``ITERATION_LIMIT`` (``TIME_LIMIT`` if the clock cut a
   line). PRM builds an empty roadmap and its query checks the lines; PRM*'s first round
   connects start and goals without a sample.

With samples allowed, checking the straight line before the first sample is each planner's
own choice (RRT-Connect and PRM's query do). The compiled RRT-Connect follows the same rule.

A planner stops at whichever limit comes first. Its result says which one: status
:attr:`~taskspace.planning.PlannerStatus.TIME_LIMIT` or ``ITERATION_LIMIT`` when no path was
found (the anytime planners return ``SOLVED`` with the best path found), and every planner's
``log`` holds ``stopped_by`` (``"time"``, ``"iterations"``, ``"first solution"``,
``"optimal"``, ``"no path"``, ``"uncertified"`` when ``certify=True`` found no certified path)
and the cost over time, ``costs`` and ``cost_times`` [s]: one entry for the planners that
return their first path (:func:`limit_log`), every improvement for the anytime ones.

Overrun: RRT, the Python RRT-Connect, RRT*, BIT*, the kinodynamic RRT, and the path
post-processors :func:`~taskspace.planning.shortcut_path` and
:func:`~taskspace.planning.smooth_bspline` read the clock before every edge check, so they
overrun the time limit by one edge check at most (the compiled RRT-Connect reads it every 16
checks). A line of several steps (RRT-Connect's CONNECT) is checked step by step and a lazy
fine pass over a candidate path edge by edge (:meth:`Budget.first_invalid`); a long straight
edge (a start-goal line, a shortcut) batch by batch (:meth:`Budget.motion_valid`). Work cut
short by the deadline is not kept unless it was checked to its end (RRT-Connect keeps the
steps of a line checked free as nodes; a shortcut or smoothing move not checked in full is
dropped), and the result says ``TIME_LIMIT``. Certified planning reads it before each
distance query of the certification (:func:`~taskspace.planning.certify.certify_planned`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from taskspace._validation import MAX_INT64, check_limits
from taskspace.planning.configuration_space import FloatArray
from taskspace.planning.planner_result import PlannerResult, PlannerStatus

_STOPPED_BY = {
    PlannerStatus.SOLVED: "first solution",
    PlannerStatus.TIME_LIMIT: "time",
    PlannerStatus.ITERATION_LIMIT: "iterations",
    PlannerStatus.NO_PATH: "no path",
    PlannerStatus.UNCERTIFIED: "uncertified",
}


def limit_log(status: PlannerStatus, cost: float, time_s: float) -> dict[str, Any]:
    """The log fields of a planner that returns its first path (the anytime planners' names).

    Returns:
        ``stopped_by`` (``"first solution"``, ``"time"``, ``"iterations"``, ``"no path"``)
        and the cost over time: ``costs`` and ``cost_times`` [s], one entry (the path's
        cost and the time it was returned) when a path was found, else empty.
    """
    solved = status is PlannerStatus.SOLVED
    return {
        "stopped_by": _STOPPED_BY[status],
        "costs": [float(cost)] if solved else [],
        "cost_times": [float(time_s)] if solved else [],
    }


def edge_case(
    space: Any,
    q_start: FloatArray,
    goals: Sequence[FloatArray],
    region: Any,
    budget: Budget,
    *,
    lines: bool = True,
) -> tuple[FloatArray, PlannerStatus] | None:
    """The edge cases of the limits, decided before a planner's search (module docstring).

    In this order: a start inside the goal region (path ``[start]``) or equal to a goal
    (``[start, goal]``) is ``SOLVED`` whatever the limits; a deadline already passed is
    ``TIME_LIMIT``; with ``max_iterations=0`` the straight lines to the goals, nearest
    first and under the clock, give ``SOLVED`` (the first free one), ``TIME_LIMIT`` (cut)
    or ``ITERATION_LIMIT`` (``lines=False``: a planner that checks them itself, as PRM*'s
    first round does without a sample).

    Returns:
        ``(path, status)`` when these decide the result, else ``None`` (plan).
    """
    empty = np.empty((0, space.dim))
    if region is not None and region.contains(q_start):
        return q_start[None, :].copy(), PlannerStatus.SOLVED
    for q_goal in goals:
        if np.array_equal(q_goal, q_start):
            return np.stack([q_start, q_goal]), PlannerStatus.SOLVED
    if budget.out_of_time():
        return empty, PlannerStatus.TIME_LIMIT
    if budget.cap > 0 or not lines:
        return None
    order = np.argsort(space.distances(np.asarray(goals), q_start)).tolist() if goals else []
    for g in order:
        free = budget.motion_valid(space, q_start, goals[g])
        if free is None:
            return empty, PlannerStatus.TIME_LIMIT
        if free:
            return np.stack([q_start, goals[g]]), PlannerStatus.SOLVED
    budget.stopped_by = "iterations"
    return empty, PlannerStatus.ITERATION_LIMIT


def edge_case_result(
    space: Any,
    found: tuple[FloatArray, PlannerStatus],
    budget: Budget,
    counts: tuple[int, int],
    objective: Any = None,
    goal_count: int = 1,
) -> PlannerResult:
    """The result of a planner stopped by :func:`edge_case` (no iteration ran).

    Args:
        space: the planner's space.
        found: :func:`edge_case`'s answer.
        budget: the planner's budget (its start time).
        counts: ``space.checks`` and ``space.edge_checks`` at the planner's start.
        objective: the optimal planners' objective (``cost`` is its cost of the path);
            ``None`` for the planners without one (``cost`` is ``None``).
        goal_count: goal configurations (``log["goal_states"]``).
    """
    path, status = found
    success = status is PlannerStatus.SOLVED
    length = result_length(space, path, success)
    cost = None
    if objective is not None:
        cost = float(objective.path_cost(path)) if success else math.inf
    dt = budget.elapsed()
    return PlannerResult(
        success=success,
        status=status,
        path=path,
        path_length=length,
        iterations=0,
        collision_checks=space.checks - counts[0],
        edge_checks=space.edge_checks - counts[1],
        time_s=dt,
        cost=cost,
        log={
            "edge_case": 1.0,
            "goal_states": float(goal_count),
            **limit_log(status, length if cost is None else cost, dt),
        },
    )


def result_length(space: Any, path: Any, success: bool) -> float:
    """The ``path_length`` a planner reports: ``space.path_length(path)``, ``inf`` on failure.

    The one place every planner's result takes its length from, so that it is in the space's
    metric (weighted, Pinocchio's ``difference`` on a joint manifold) and never the Euclidean
    length of the raw coordinates (quaternion components of a floating base).
    """
    return float(space.path_length(path)) if success else math.inf


def planner_limits(max_iterations: Any, time_limit_s: Any) -> tuple[int, float]:
    """Validate the limits of a planner (see the module docstring).

    Args:
        max_iterations: iteration cap (an integer >= 0) or ``None``.
        time_limit_s: time limit [s] or ``None``.

    Returns:
        ``(cap, limit)``: the cap as an int (``2**63 - 1`` for none) and the limit [s]
        (``math.inf`` for none).

    Raises:
        InvalidInputError: a bad value, or no finite limit at all.
    """
    cap, limit = check_limits(max_iterations, time_limit_s)
    return (MAX_INT64 if cap is None else cap), limit


class Budget:
    """Iterations and wall-clock time left to a planner (one object per call).

    Args:
        max_iterations: validated cap (see :func:`planner_limits`).
        time_limit_s: validated limit [s] (``math.inf`` for none).
        t0: start time (``time.perf_counter()``) [s].
    """

    def __init__(self, max_iterations: int, time_limit_s: float, t0: float) -> None:
        self.cap = max_iterations
        self.deadline = t0 + time_limit_s
        self.t0 = t0
        self.stopped_by = ""

    def out_of_time(self) -> bool:
        """True (and ``stopped_by = "time"``) once the deadline has passed."""
        if time.perf_counter() > self.deadline:
            self.stopped_by = "time"
            return True
        return False

    def exhausted(self, iterations: int) -> bool:
        """True once ``iterations`` reached the cap or the time ran out."""
        if iterations >= self.cap:
            self.stopped_by = "iterations"
            return True
        return self.out_of_time()

    def first_invalid(
        self, check: Callable[[Any], int], points: Any, bounds: Sequence[int]
    ) -> tuple[int, int]:
        """Check rows of ``points`` in order, group by group, reading the clock before each.

        The groups are ``points[bounds[k - 1]:bounds[k]]`` (``bounds`` increasing, its last
        entry ``len(points)``; the first group starts at row 0); each group (one edge or one
        step of a line) is one ``check`` call (a checker's ``first_invalid``). No group starts
        after the deadline, so the overrun is one group at most.

        Returns:
            ``(bad, stop)``: ``bad`` the first invalid row (-1: none among the rows checked)
            and ``stop`` the number of rows checked and free before it; the rows were all
            checked when ``bad >= 0`` or ``stop == len(points)``, otherwise the time ran out
            (``stopped_by = "time"``) and rows ``stop:`` were not checked.
        """
        if self.deadline == math.inf:  # no time limit: one call for all the rows
            total = bounds[-1] if len(bounds) else 0
            bad = check(points[:total]) if total else -1
            return (bad, bad) if bad >= 0 else (-1, total)
        lo = 0
        for hi in bounds:
            if hi <= lo:
                continue
            if self.out_of_time():
                return -1, lo
            bad = check(points[lo:hi])
            if bad >= 0:
                return lo + bad, lo + bad
            lo = hi
        return -1, lo

    def motion_valid(self, space: Any, q0: Any, q1: Any, *, check_end: bool = False) -> bool | None:
        """``space.motion_valid(q0, q1)`` with the clock read before each checker call.

        The same points in the same order and batches (bisection order, batches growing
        1, 4, 16, ... up to ``space.edge.max_batch``); a long edge (a straight start-goal line,
        a shortcut) costs many batches, so the overrun is one batch, not one edge.

        Returns:
            True (free), False (a point collides) or ``None``: the deadline passed before
            the edge was checked to its end (``stopped_by = "time"``; not known free).
        """
        space.edge_checks += 1
        if check_end:
            if self.out_of_time():
                return None
            if space.checker.first_invalid(q1[None, :]) >= 0:
                return False
        points, bounds = space.edge_points(q0, q1)
        if not bounds:
            return True
        bad, checked = self.first_invalid(space.checker.first_invalid, points, bounds)
        if bad >= 0:
            return False
        return True if checked == bounds[-1] else None

    def elapsed(self) -> float:
        """Seconds since ``t0``."""
        return time.perf_counter() - self.t0
