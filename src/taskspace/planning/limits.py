"""The one limit convention of every sampling-based planner of taskspace.

Every planner's ``Options`` has ``max_iterations`` and ``time_limit_s`` (two exceptions
below):

* ``max_iterations``: an integer >= 0, or ``None`` for no cap (then the time limit must be
  finite). What one iteration is depends on the planner and is named in its options (one
  sample for the RRT family, PRM* and BIT*; one growth round for Lazy PRM);
* ``time_limit_s``: a wall-clock budget [s], ``None`` or ``math.inf`` for none (then the
  iteration cap must be an integer); NaN, negative numbers and bools are refused.

Two planners name their cap otherwise (same validation, same statuses):
:func:`~taskspace.planning.prm.prm` and :func:`~taskspace.planning.prm.build_prm` take
``PRMOptions.n_samples`` (roadmap nodes, the cap) and ``PRMOptions.time_limit_s``;
:func:`~taskspace.planning.lazy_prm.lazy_prm` takes the keyword ``max_rounds`` (growth rounds,
at least 1) and ``time_limit_s`` as a keyword or in ``PRMOptions`` (given twice, they must agree).

A planner stops at whichever limit comes first; its result says which one
(:attr:`~taskspace.planning.PlannerStatus.TIME_LIMIT` or ``ITERATION_LIMIT`` when no path was
found, ``log["stopped_by"]`` for the anytime planners, which return ``SOLVED`` with the best
path found).
"""

from __future__ import annotations

import time
from typing import Any

from taskspace._validation import MAX_INT64, check_limits


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
