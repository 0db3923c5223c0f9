"""Rapidly-exploring random trees, plain and goal-biased (slides 3:37-3:41).

Slide 3:39 (plain) and 3:40 (goal-biased, with probability ``beta``)::

    V = {q_start}, E = {}
    for i = 0..n:
        q_target <- q_goal with probability beta, else a random sample from Q
        q_near   <- nearest neighbour of q_target in V
        q_new    <- q_near + alpha / |q_target - q_near| (q_target - q_near)
        if q_new in Q_free: V <- V + {q_new}, E <- E + {(q_near, q_new)}

Here ``q_new`` is accepted when the whole segment ``q_near -> q_new`` is free (straight-line
local planner, slide 3:32), and the search succeeds when a new node lies within ``alpha`` of
``q_goal`` and the segment to it is free. Without a goal the tree just grows for ``n``
iterations (the figures of slide 3:38).

On a joint-manifold space (continuous joints, planar or floating bases) distances are the
space's metric, nearest neighbours are taken in it, and ``q_new`` is the point at ``alpha``
along the geodesic ``q_near (+) t (q_target (-) q_near)`` (Pinocchio's ``interpolate``).

Thread safety: :class:`RRTOptions` is immutable; the planners keep their state local to the call
apart from the configuration space (one space per thread) and generator they are given.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import check_positive, check_seed
from taskspace.errors import InvalidInputError
from taskspace.planning.certify import FailedRegions, plan_certified
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray
from taskspace.planning.goals import REGION_FIRST_ATTEMPTS, goal_states, region_samples
from taskspace.planning.limits import (
    Budget,
    edge_case,
    edge_case_result,
    limit_log,
    planner_limits,
    result_length,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.rrt_connect import _GrowingTree, _steer

logger = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class RRTOptions:
    """Settings of :func:`rrt`.

    Attributes:
        step_size: extension step ``alpha`` [rad or m] (slide 3:39).
        goal_bias: probability ``beta`` of taking ``q_goal`` as target (slide 3:40).
        max_iterations: number of iterations ``n`` (an integer >= 0, or ``None`` with a
            finite time limit: :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = no limit; NaN is
            refused).
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
        certify: prove the returned path free between its checked points
            (:func:`~taskspace.planning.certify_path`, conservative advancement on the robot's
            geometry); an uncertified path is re-planned with the next seeds
            (``certify_retries`` times, within the time limit), and if none can be certified
            the result has ``success=False`` and status ``UNCERTIFIED``. Needs a space built
            on a robot.
        certify_retries: re-plans (next seeds) after an uncertified path; a re-plan accepts a
            motion near a spot where an earlier certificate failed only if it is certified
            there (:class:`~taskspace.planning.certify.FailedRegions`).
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
    """

    step_size: float = 0.5
    goal_bias: float = 0.05
    max_iterations: int | None = 10_000
    time_limit_s: float | None = 5.0
    seed: int = 0
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4


def rrt(
    space: ConfigurationSpace,
    start: Any,
    goal: Any = None,
    options: RRTOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Grow an RRT from ``start``, towards ``goal`` if given (slides 3:39-3:40).

    Threads: Python code (the GIL runs one thread at a time; Ctrl-C interrupts it). Plans in
    several threads give the results of sequential runs when each thread has its own space
    (checker) and ``rng``; a compiled checker shared by threads is locked, a space's counters
    and a Python checker are not.

    Args:
        space: configuration space with validity checker and local planner.
        start: ``q_start`` (size d).
        goal: ``q_goal`` (size d); several goal configurations (k, d) (the goal bias
            draws one of them; the path ends at the first one a new node reaches); a
            :class:`~taskspace.planning.GoalRegion` (its valid samples among 20, and one
            more every 64 iterations up to 32, are the goal states; a new node inside the
            region also ends the path; a start inside it is a one-point path): see
            :mod:`taskspace.planning.goals`. ``None`` grows for ``max_iterations``
            iterations.
        options: planner settings (``alpha``, ``beta``, limits).
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        A :class:`PlannerResult` with the tree in ``trees[0]``; without goal ``success`` is
        False and ``status`` is ``ITERATION_LIMIT`` (or ``TIME_LIMIT``). With
        ``options.certify``: ``log`` has ``certified``, ``min_distance`` [m] and
        ``certify_attempts`` (:func:`~taskspace.planning.certify.certify_planned`).

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: invalid options; ``certify`` on a space without a robot.

    Certified paths: with ``options.certify`` the returned path is proven free between its
    checked points by :func:`~taskspace.planning.certify_path`; an uncertified path is
    re-planned with the next seeds (``certify_retries`` times, within the time limit, which
    covers the certification) and, if none can be certified, the result has
    ``success=False``, status ``UNCERTIFIED`` and the failing segment in ``log``.
    """
    opts = options or RRTOptions()
    if not opts.certify:
        return _plan(space, start, goal, opts, rng)
    return plan_certified(space, opts, lambda o, r: _plan(space, start, goal, o, rng, r))


def _plan(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: RRTOptions,
    rng: np.random.Generator | None,
    regions: FailedRegions | None = None,
) -> PlannerResult:
    """:func:`rrt` without certification.

    ``regions``: the failed regions of earlier certificates (a certified re-plan): every tree
    edge, goal edge and straight line must be certified inside them
    (:class:`~taskspace.planning.certify.FailedRegions`).
    """
    alpha = check_positive(opts.step_size, "step_size")
    if not 0.0 <= opts.goal_bias <= 1.0:
        raise InvalidInputError(f"goal_bias must be in [0, 1], got {opts.goal_bias}")
    max_iterations, time_limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    rng = rng if rng is not None else np.random.default_rng(check_seed(opts.seed))
    checks0, edges0 = space.checks, space.edge_checks
    t0 = time.perf_counter()
    q_start = space.check_endpoint(start, "start")
    budget = Budget(max_iterations, time_limit, t0)
    deadline = budget.deadline
    goals: list[FloatArray] = []
    region = None
    if goal is not None:
        goals, region = goal_states(space, goal)
        if region is not None:
            goals = region_samples(space, region, rng, REGION_FIRST_ATTEMPTS, deadline)
    found = edge_case(space, q_start, goals, region, budget) if goal is not None else None
    if found is not None and regions is not None:
        found = regions.edge_case(found)
    if found is not None:
        return edge_case_result(space, found, budget, (checks0, edges0), goal_count=len(goals))
    euclidean = space.is_euclidean
    tree = _GrowingTree(q_start, None if euclidean else space.distances)
    status = PlannerStatus.ITERATION_LIMIT
    path: FloatArray = np.empty((0, space.dim))
    iterations = 0
    if region is not None and region.contains(q_start):
        path, status, max_iterations = q_start[None, :].copy(), PlannerStatus.SOLVED, 0
    for iterations in range(1, max_iterations + 1):
        if budget.out_of_time():
            status = PlannerStatus.TIME_LIMIT
            break
        if region is not None and iterations % _REGION_EVERY == 0 and len(goals) < 32:
            goals += region_samples(space, region, rng, 1, deadline)
        if goal is not None and rng.random() < opts.goal_bias and (goals or region is None):
            q_target = goals[0] if len(goals) == 1 else goals[int(rng.integers(len(goals)))]
        else:
            q_target = space.sample_uniform(rng)
        i_near, dist = tree.nn.nearest(q_target)
        if dist == 0.0:
            continue
        q_near = tree.nn.points[i_near]
        if euclidean:
            q_new = _steer(q_near, q_target, dist, alpha)
        else:  # along the geodesic, at most alpha in the space's metric
            q_new = (
                q_target.copy()
                if dist <= alpha
                else space.interpolate(q_near, q_target, alpha / dist)[0]
            )
        free = budget.motion_valid(space, q_near, q_new, check_end=True)
        if free is None:  # the deadline passed during the edge: no node
            status = PlannerStatus.TIME_LIMIT
            break
        if not free or (regions is not None and not regions.allows(q_near, q_new)):
            continue
        i_new = tree.add(q_new, i_near)
        if region is not None and region.contains(q_new):
            path = tree.freeze().path_to(i_new)  # inside the region: a goal configuration
            status = PlannerStatus.SOLVED
            break
        i_goal = _reach_goal(space, tree, i_new, goals, alpha, budget, regions)
        if i_goal == _LATE:  # the new node stays, the goal edge is not known free
            status = PlannerStatus.TIME_LIMIT
            break
        if i_goal >= 0:
            path = tree.freeze().path_to(i_goal)
            status = PlannerStatus.SOLVED
            break
    dt = time.perf_counter() - t0
    success = status is PlannerStatus.SOLVED
    logger.debug("rrt %s in %.3f s, %d nodes", status.value, dt, len(tree.nn))
    return PlannerResult(
        success=success,
        status=status,
        path=path,
        path_length=result_length(space, path, success),
        iterations=iterations,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=dt,
        trees=[tree.freeze()],
        log={
            "goal_states": float(len(goals)),
            **limit_log(status, result_length(space, path, success), dt),
        },
    )


_REGION_EVERY = 64
"""A goal region is sampled again every this many iterations (up to 32 goal states)."""


_LATE = -2
""":func:`_reach_goal`'s answer when the deadline passed before a goal edge was checked."""


def _reach_goal(
    space: ConfigurationSpace,
    tree: _GrowingTree,
    i_new: int,
    goals: list[FloatArray],
    alpha: float,
    budget: Budget,
    regions: FailedRegions | None = None,
) -> int:
    """The tree node of a goal within ``alpha`` of node ``i_new`` joined to it free, or -1.

    Goals are tried nearest first; a goal at ``q_new`` itself is ``i_new``. The clock is read
    before each checker call (:meth:`Budget.motion_valid`): :data:`_LATE` when the deadline
    passed before a goal edge was checked to its end.
    """
    if not goals:
        return -1
    q_new = tree.nn.points[i_new]
    if len(goals) == 1:
        gaps = np.array([space.distance(q_new, goals[0])])
    else:
        gaps = space.distances(np.asarray(goals), q_new)
    for g in np.argsort(gaps, kind="stable").tolist():
        if gaps[g] > alpha:
            break
        free = budget.motion_valid(space, q_new, goals[g])
        if free is None:
            return _LATE
        if free and regions is not None:
            free = regions.allows(q_new, goals[g])
        if free:
            return i_new if gaps[g] == 0.0 else tree.add(goals[g], i_new)
    return -1
