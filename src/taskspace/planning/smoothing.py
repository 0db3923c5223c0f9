"""B-spline smoothing of a collision-free waypoint path (OMPL's ``smoothBSpline``).

Each pass first subdivides the path so that consecutive waypoints are at most ``max_step``
apart (:func:`~taskspace.planning.interpolate`), then moves every other interior waypoint
``q_i`` to the average of the midpoints of its two edges,

    q_i' = (q_{i-1} + 2 q_i + q_{i+1}) / 4,

the corner-cutting step of subdivision schemes whose limit is a quadratic B-spline (Chaikin
1974); the next pass moves the other half. A move is kept only if ``q_i'`` is free and both
new segments ``q_{i-1} -> q_i'`` and ``q_i' -> q_{i+1}`` are free at the space's resolution
(the straight-line local planner), so every segment of the result is checked as the planner
checks its edges; ``q_i'`` lies in the triangle ``q_{i-1} q_i q_{i+1}``, so the path never
gets longer. The input is checked first and a colliding input is refused, and the whole result
is checked again before it is returned.

Certification: those checks are at the space's resolution (as a planner's edges without
``certify``), so a cut corner may graze an obstacle between checked points. For a path
proven free between its points, certify the smoothed path
(:func:`~taskspace.planning.certify.certify_path`) and keep the planner's certified path when
the proof fails: the example of :func:`smooth_bspline`.

Time limit: the passes read the clock before every checker call
(:meth:`~taskspace.planning.limits.Budget.motion_valid`), so they stop one batch of an edge's
points past the limit at most; a move whose segments were not both checked is dropped. The
checks of the input and of the result are not counted (as :func:`shortcut_path`'s input
check): they run in full whatever the limit.

On a joint-manifold space (continuous joints, planar or floating bases) the same corner cut
is taken in the tangent space at ``q_i``:
``q_i' = q_i (+) ((q_{i-1} (-) q_i) + (q_{i+1} (-) q_i)) / 4`` (Pinocchio's ``difference`` and
``integrate``), segments are the space's geodesics, lengths are in its metric, and a move is
kept only if it does not lengthen the two segments (the weighted metric of SE(3) need not obey
the triangle inequality along such a cut).

Thread safety: :class:`SmoothingOptions` is immutable; the smoothers keep their state local to the
call apart from the configuration space (one space per thread) they are given; a
:class:`SmoothingResult` is plain result data, not locked.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from taskspace._validation import check_positive
from taskspace.errors import InvalidInputError, PlanningError
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    FloatArray,
    as_path,
    interpolated_counts,
)
from taskspace.planning.limits import Budget, planner_limits
from taskspace.planning.rrt_star import interpolate
from taskspace.planning.shortcut import _check_input


@dataclass(frozen=True, kw_only=True)
class SmoothingOptions:
    """Settings of :func:`smooth_bspline`.

    Attributes:
        max_step: largest distance between waypoints after the subdivision of each pass
            [rad or m] (the scale of the smoothing: corners are rounded over about this
            length).
        max_iterations: smoothing passes (an integer >= 0, or ``None`` with a finite time
            limit; see :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] of the passes (not counting the checks of the
            input and of the result), kept to one batch of an edge's points (``None`` or
            ``math.inf`` = none; NaN refused).
        min_change: stop when a pass shortens the path by less than this fraction.
    """

    max_step: float = 0.2
    max_iterations: int | None = 5
    time_limit_s: float | None = 1.0
    min_change: float = 1e-4


@dataclass
class SmoothingResult:
    """Smoothed path.

    Attributes:
        path: waypoints, shape (m, d); every waypoint and segment free at the space's
            resolution.
        length_before: input length [rad or m].
        length_after: output length [rad or m] (never more than the input's).
        passes: smoothing passes run.
        moved: waypoint moves accepted.
        rejected: moves refused because a new segment or point collided.
        collision_checks: configurations evaluated (including the input and output checks).
        time_s: wall-clock time [s].
    """

    path: FloatArray
    length_before: float
    length_after: float
    passes: int
    moved: int
    rejected: int
    collision_checks: int
    time_s: float


def smooth_bspline(
    space: ConfigurationSpace, path: object, options: SmoothingOptions | None = None
) -> SmoothingResult:
    """Round the corners of a collision-free path, keeping it free (see the module docstring).

    Args:
        space: configuration space (its local planner checks every new segment).
        path: waypoints from start to goal, shape (m, d), collision-free (a 1-D array as
            :func:`~taskspace.planning.configuration_space.as_path` reads it).
        options: settings.

    Returns:
        A :class:`SmoothingResult` with the same end points, no longer than the input.

    Raises:
        InvalidInputError: ``path`` is not a finite (m, d) array, bad options.
        PlanningError: ``path`` leaves the bounds or collides (the message names the first
            offending waypoint or edge).

    Example:
        A smooth path proven free between its points (the smoothing checks its segments at
        the space's resolution only): certify the smoothed path and keep the planner's
        certified path when the proof fails::

            result = rrt_connect(space, start, goal, RRTConnectOptions(certify=True))
            smooth = smooth_bspline(space, result.path).path
            if certify_path(robot, smooth).certified:
                path = smooth
            else:  # a cut corner closer to an obstacle than the tolerance
                path = result.path  # certified by the planner

        With ``locked_joints``, certify the robot's configurations:
        ``certify_path(robot, space.locked.lift(smooth))``.
    """
    opts = options or SmoothingOptions()
    arr = as_path(path, space.dim)
    step = check_positive(opts.max_step, "max_step")
    passes_cap, limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    if not 0.0 <= opts.min_change < 1.0:
        raise InvalidInputError(f"min_change must be in [0, 1), got {opts.min_change}")
    t0 = time.perf_counter()
    checks0 = space.checks
    _check_input(space, arr, "smooth_bspline")
    # each pass cuts the path every max_step: refuse one that would not fit in memory
    interpolated_counts([space.path_length(arr)], step, space.dim, "max_step")
    budget = Budget(passes_cap, limit, time.perf_counter())
    before = space.path_length(arr)
    # Densified pieces are taken unchecked first (the final guard checks the whole path);
    # a thin obstacle between the resolution's samples of an input segment can put a new
    # waypoint or piece in collision: then the passes run again with every piece checked.
    current, moved, rejected, passes = _passes(
        space, arr, step, passes_cap, budget, opts.min_change, checked=False
    )
    if not space.path_valid(current):
        current, moved, rejected, passes = _passes(
            space, arr, step, passes_cap, budget, opts.min_change, checked=True
        )
        if not space.path_valid(current):  # every piece and move was checked: the guard
            raise PlanningError(
                "smooth_bspline produced a path that is not free at the space's resolution; "
                "this is a bug, please report it (the input path was free)"
            )
    return SmoothingResult(
        path=current,
        length_before=before,
        length_after=space.path_length(current),
        passes=passes,
        moved=moved,
        rejected=rejected,
        collision_checks=space.checks - checks0,
        time_s=time.perf_counter() - t0,
    )


def _passes(
    space: ConfigurationSpace,
    arr: FloatArray,
    step: float,
    passes_cap: int | float,
    budget: Budget,
    min_change: float,
    checked: bool,
) -> tuple[FloatArray, int, int, int]:
    """The smoothing passes from ``arr``: (path, moved, rejected, passes).

    ``budget`` holds the time limit of the whole call (both runs of the passes share it).
    """
    current = arr.copy()
    moved = rejected = passes = 0
    late = False
    while passes < passes_cap and current.shape[0] > 2 and not late and not budget.out_of_time():
        passes += 1
        length0 = space.path_length(current)
        current = _densify(space, current, step, checked)
        for parity in (1, 2):
            for i in range(parity, current.shape[0] - 1, 2):
                if late:
                    break
                a, b, c = current[i - 1], current[i], current[i + 1]
                if space.manifold is None:
                    q = 0.25 * a + 0.5 * b + 0.25 * c
                else:  # the same step in the tangent space at b
                    step_b = 0.25 * (space.tangent_step(b, a) + space.tangent_step(b, c))
                    q = space.retract(b, step_b)
                if np.allclose(q, b, rtol=0.0, atol=1e-12):
                    continue
                if space.manifold is not None and space.distance(a, q) + space.distance(
                    q, c
                ) > space.distance(a, b) + space.distance(b, c):
                    rejected += 1  # the manifold's metric need not shrink the corner
                    continue
                free: bool | None = space.outside_limits(q).size == 0
                if free:  # the new point, then its two segments, the clock read before each
                    free = budget.motion_valid(space, a, q, check_end=True)
                if free:
                    free = budget.motion_valid(space, q, c)
                if free is None:
                    late = True  # out of time: the move is dropped
                elif free:
                    current[i] = q
                    moved += 1
                else:
                    rejected += 1
        if length0 - space.path_length(current) <= min_change * length0:
            break
    return current, moved, rejected, passes


def _densify(space: ConfigurationSpace, path: FloatArray, step: float, checked: bool) -> FloatArray:
    """``path`` with points inserted every ``step`` at most (``checked``: where they are free).

    A segment free at the space's resolution need not have free pieces: the new waypoints and
    the pieces' own points (``k / n`` of each piece) are not the points the segment's check
    visited (a thin obstacle between two of them). With ``checked``, a segment with a colliding
    new waypoint or piece is kept whole.
    """
    if not checked:
        return (
            interpolate(path, step)
            if space.manifold is None
            else space.interpolate_path(path, step)
        )
    out = [path[:1]]
    for a, b in itertools.pairwise(path):
        pair = np.stack([a, b])
        seg = (
            interpolate(pair, step)
            if space.manifold is None
            else space.interpolate_path(pair, step)
        )
        if seg.shape[0] > 2 and not space.path_valid(seg):
            seg = pair
        out.append(seg[1:])
    return np.vstack(out)
