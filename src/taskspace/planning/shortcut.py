"""Path shortcutting: shorten a collision-free waypoint path with straight segments.

Two passes, both using the straight-line local planner (slide 3:32):

1. greedy vertex reduction: from waypoint ``i`` jump to the farthest waypoint ``j`` such that
   the segment ``q_i -> q_j`` is in Q_free;
2. random shortcuts: pick two points ``q(s_1), q(s_2)`` at random arc lengths
   ``s_1 < s_2`` of the path; if the segment between them is in Q_free, it replaces the
   part of the path between them when it is shorter than the part it replaces (the path
   never gets longer).
   The two cut pieces of the old edges are checked as well: a piece of an edge checked at
   the points ``k / n`` is a new segment whose own points ``k / n'`` were not checked, and
   the result must be free at the resolution ``delta`` segment by segment.

Time limit: both passes read the clock before every checker call
(:meth:`~taskspace.planning.limits.Budget.motion_valid`), so they stop one batch of an edge's
points past the limit at most. A greedy pass cut short keeps the jumps it has proven and the
rest of the path as it was; a random shortcut whose segments were not all checked is dropped.

On a joint-manifold space (continuous joints, planar or floating bases) the segments are the
space's geodesics (``pinocchio.interpolate``), arc lengths are measured in its metric
``|W (q1 (-) q0)|`` and the cut points lie on the geodesics.

Thread safety: :class:`ShortcutOptions` is immutable; :func:`shortcut_path` keeps its state local
to the call apart from the configuration space (one space per thread) and generator it is given; a
:class:`ShortcutResult` is plain result data, not locked.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from taskspace._validation import check_count, check_seed, check_time_limit
from taskspace.errors import PlanningError
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray, as_path
from taskspace.planning.limits import Budget


@dataclass(frozen=True, kw_only=True)
class ShortcutOptions:
    """Settings of :func:`shortcut_path`.

    Attributes:
        max_iterations: random shortcut attempts (an integer >= 0).
        time_limit_s: wall-clock budget [s] of the shortening (the greedy pass and the
            random shortcuts; the check of the input path is not counted), kept to one batch
            of an edge's points (``None`` or ``math.inf`` = no limit; NaN is refused).
        greedy: run the greedy vertex-reduction pass first.
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
    """

    max_iterations: int = 60
    time_limit_s: float | None = 0.2
    greedy: bool = True
    seed: int = 0


@dataclass
class ShortcutResult:
    """Shortened path.

    Attributes:
        path: waypoints, shape (m, d).
        length_before: input length [rad or m].
        length_after: output length [rad or m].
        accepted: shortcuts accepted (greedy jumps and random shortcuts).
        collision_checks: configurations evaluated.
        time_s: wall-clock time [s].
    """

    path: FloatArray
    length_before: float
    length_after: float
    accepted: int
    collision_checks: int
    time_s: float


def _point_at(
    space: ConfigurationSpace, path: FloatArray, cumulative: FloatArray, s: float
) -> tuple[int, FloatArray]:
    """Segment index ``i`` and the point at arc length ``s`` on segment ``i -> i + 1``.

    The point is on the local path (the geodesic on a joint manifold, at ``t d`` from
    ``q_i``).
    """
    i = int(np.searchsorted(cumulative, s, side="right") - 1)
    i = min(max(i, 0), path.shape[0] - 2)
    seg = cumulative[i + 1] - cumulative[i]
    t = 0.0 if seg <= 0 else (s - cumulative[i]) / seg
    return i, space.interpolate(path[i], path[i + 1], [t])[0]


def _check_input(
    space: ConfigurationSpace, path: FloatArray, caller: str = "shortcut_path"
) -> None:
    """Raise :class:`PlanningError` unless every waypoint and edge of ``path`` is free.

    ``caller`` is the public function named in the message.
    """
    if space.manifold is not None:
        for i, q in enumerate(path):
            if space.manifold.unit_error(q) > 1e-6:
                raise PlanningError(
                    f"path waypoint {i} is not a valid configuration: a quaternion or "
                    "(cos, sin) pair is not of unit norm; normalize it (pinocchio.normalize)"
                )
    outside = space.outside_limits(path)
    if outside.size:
        i = int(outside[0])
        raise PlanningError(
            f"path waypoint {i} is outside the bounds of the space: {path[i].tolist()}"
        )
    bad = space.first_invalid(path)
    if bad >= 0:
        raise PlanningError(
            f"path waypoint {bad} is in collision: {space.checker.explain(path[bad])}; "
            f"{caller} needs a collision-free path"
        )
    for i in range(path.shape[0] - 1):
        if not space.motion_valid(path[i], path[i + 1]):
            raise PlanningError(
                f"path edge {i} -> {i + 1} is in collision at the resolution "
                f"{space.edge.resolution:g}; {caller} needs a collision-free path"
            )


def shortcut_path(
    space: ConfigurationSpace,
    path: FloatArray,
    options: ShortcutOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> ShortcutResult:
    """Shorten a collision-free path (greedy vertex reduction, then random shortcuts).

    The input path is checked first (every waypoint inside the bounds and free, every edge
    free at the space's resolution, as the local planner checks it); every segment of the
    result is free at that resolution too, so a free path stays free and a colliding one is
    refused instead of being returned shortened.

    Threads: Python code (the GIL runs one thread at a time; Ctrl-C interrupts it). Plans in
    several threads give the results of sequential runs when each thread has its own space
    (checker) and ``rng``; a compiled checker shared by threads is locked, a space's counters
    and a Python checker are not.

    Args:
        space: configuration space (its local planner checks the segments).
        path: waypoints from start to goal, shape (m, d), collision-free (a 1-D array as
            :func:`~taskspace.planning.configuration_space.as_path` reads it).
        options: settings.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        A :class:`ShortcutResult` whose path has the same endpoints and is no longer;
        ``collision_checks`` includes the check of the input.

    Raises:
        InvalidInputError: ``path`` is not a finite (m, d) array with m >= 1, bad options.
        PlanningError: ``path`` leaves the bounds or collides (the message names the first
            offending waypoint or edge).
    """
    opts = options or ShortcutOptions()
    arr = as_path(path, space.dim).copy()
    max_iterations = check_count(opts.max_iterations, "max_iterations")
    time_limit = check_time_limit(opts.time_limit_s)
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    t0 = time.perf_counter()
    checks0 = space.checks
    _check_input(space, arr)
    budget = Budget(max_iterations, time_limit, time.perf_counter())
    before = space.path_length(arr)
    accepted = 0
    if opts.greedy and arr.shape[0] > 2:
        keep = [0]
        i = 0
        m = arr.shape[0]
        while i < m - 1:
            j = m - 1
            while j > i + 1:
                free = budget.motion_valid(space, arr[i], arr[j])
                if free is None:  # out of time: the rest of the path as it was
                    j = -1
                    break
                if free:
                    break
                j -= 1
            if j < 0:
                keep.extend(range(i + 1, m))
                break
            accepted += j > i + 1
            keep.append(j)
            i = j
        arr = arr[keep]
    for _ in range(max_iterations):
        if arr.shape[0] < 2 or budget.out_of_time():
            break
        cumulative = np.concatenate([[0.0], np.cumsum(space.distances(arr[:-1], arr[1:]))])
        total = float(cumulative[-1])
        if total <= 0:
            break
        s1, s2 = np.sort(rng.uniform(0.0, total, 2))
        i1, p1 = _point_at(space, arr, cumulative, float(s1))
        i2, p2 = _point_at(space, arr, cumulative, float(s2))
        if i1 == i2:
            continue  # same segment: already straight
        new_length = space.distance(p1, p2)
        if new_length >= s2 - s1 - 1e-12:
            continue
        # The pieces q_i1 -> p1 and p2 -> q_(i2+1) lie on free edges but are new segments whose
        # own points (k / n of each piece) were never checked: check them too, so that every
        # segment of the result is free at the resolution delta. So are the new waypoints p1
        # and p2 themselves (check_end): they lie between the checked points of their edges,
        # where an edge free at the resolution may still graze an obstacle.
        free = budget.motion_valid(space, p1, p2, check_end=True)
        if free:
            free = budget.motion_valid(space, arr[i1], p1, check_end=True)
        if free:
            free = budget.motion_valid(space, p2, arr[i2 + 1])
        if free is None:
            break  # out of time: the shortcut is dropped
        if not free:
            continue
        arr = np.vstack([arr[: i1 + 1], p1, p2, arr[i2 + 1 :]])
        accepted += 1
    after = space.path_length(arr)
    return ShortcutResult(
        path=arr,
        length_before=before,
        length_after=after,
        accepted=accepted,
        collision_checks=space.checks - checks0,
        time_s=time.perf_counter() - t0,
    )
