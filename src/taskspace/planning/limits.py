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

A planner stops at whichever limit comes first. Its result says which one: status
:attr:`~taskspace.planning.PlannerStatus.TIME_LIMIT` or ``ITERATION_LIMIT`` when no path was
found (the anytime planners return ``SOLVED`` with the best path found), and every planner's
``log`` holds ``stopped_by`` (``"time"``, ``"iterations"``, ``"first solution"``,
``"optimal"``, ``"no path"``) and the cost over time, ``costs`` and ``cost_times`` [s]: one
entry for the planners that return their first path (:func:`limit_log`), every improvement for
the anytime ones. The anytime planners read the clock before every edge check, so they
overrun the time limit by one edge check at most.
"""

from __future__ import annotations

import time
from typing import Any

from taskspace._validation import MAX_INT64, check_limits
from taskspace.planning.planner_result import PlannerStatus

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

    def elapsed(self) -> float:
        """Seconds since ``t0``."""
        return time.perf_counter() - self.t0
