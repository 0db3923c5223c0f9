"""RRT* and informed RRT*: asymptotically optimal, anytime sampling-based planning.

RRT* (Karaman and Frazzoli 2011) grows an RRT but connects each new node ``x_new`` to the
neighbour that gives it the least cost-to-come, then rewires every neighbour whose cost drops
when reached through ``x_new``. The neighbours are the ``k_n = k (log n)`` nearest nodes with
``k > e (1 + 1/d)``, or those within ``r_n = min(gamma (log n / n)^(1/d), eta)`` with
``gamma > gamma* = 2 (1 + 1/d)^(1/d) (mu(X_free) / zeta_d)^(1/d)``; either way the best path
converges to the optimum almost surely. Informed RRT* (Gammell, Srinivasa and Barfoot 2014), once a
path of cost ``c_best`` exists, samples only the prolate hyperspheroid with foci ``start``
and ``goal`` and transverse diameter ``c_best``: the only states that can improve the path.

Both are anytime: they run to the time or iteration limit and return the best path found,
with its cost over time in ``log``. The cost is the path length in the space's Euclidean
metric.

Thread safety: :class:`RRTStarOptions` is immutable; :func:`rrt_star` keeps its state local to the
call apart from the configuration space (one space per thread), generator and goal region it is
given (:mod:`taskspace.planning.goals`).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import check_positive, check_seed
from taskspace.errors import InvalidInputError
from taskspace.planning.certify import FailedRegions, plan_certified
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    FloatArray,
    as_path,
    interpolated_counts,
)
from taskspace.planning.goals import GoalRegion as GoalRegion  # re-exported (moved to goals)
from taskspace.planning.goals import goal_states, region_samples
from taskspace.planning.limits import (
    Budget,
    edge_case,
    edge_case_result,
    planner_limits,
    result_length,
)
from taskspace.planning.objectives import (
    OptimizationObjective,
    optimum_lower_bound,
    reached_optimum,
    space_objective,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus, Tree


@dataclass(frozen=True, kw_only=True)
class RRTStarOptions:
    """Settings of :func:`rrt_star`.

    Attributes:
        step_size: largest extension ``eta`` [rad or m].
        goal_bias: probability of sampling the goal (before a solution exists).
        gamma_factor: ``gamma = gamma_factor * gamma*`` (must exceed 1 for the guarantee).
        informed: sample the informed set once a solution exists (informed RRT*).
        max_iterations: iterations (an integer >= 0, or ``None`` with a finite time limit:
            :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = none; NaN refused).
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
        stop_at_first: return as soon as a first solution exists (not anytime).
        k_nearest: rewire the ``k_n = gamma_factor e (1 + 1/d) log n`` nearest nodes (the
            k-nearest RRT*, as OMPL does by default) instead of those within ``r_n``; in high
            dimensions the ball of radius ``r_n <= eta`` is almost always empty.
        certify: prove the returned path free between its checked points (see
            :func:`rrt_star`); needs a space built on a robot.
        certify_retries: re-plans (next seeds) after an uncertified path; a re-plan accepts a
            motion near a spot where an earlier certificate failed only if it is certified
            there (:class:`~taskspace.planning.certify.FailedRegions`).
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
        first_solution: how the first path is found. ``"rrt_connect"`` (default, with one
            goal configuration): :func:`~taskspace.planning.rrt_connect` (two trees, greedy
            connection) runs first within the same limits and its path becomes a branch of
            the RRT* tree, which RRT* then rewires and improves; its iterations count toward
            ``max_iterations``. ``"rrt_star"``: the plain goal-biased RRT* (OMPL's
            ``RRTstar``), which in 7-D needs hundreds of iterations of 0.5 rad before a
            goal sample is reached. With several goal configurations RRT-Connect aims at the
            nearest; with a :class:`GoalRegion`, at a configuration sampled from it (up to
            three samples; none valid: plain RRT*). RRT* then reaches the other goals.
        prune: once a path of cost ``c_best`` exists, skip (without collision checks) every
            new node whose admissible estimate ``f_hat(x) = c_hat(start, x) + h_hat(x)``
            (the objective's cost lower bounds) is at least ``c_best``, and every rewiring
            of a neighbour ``j`` whose new cost-to-come plus ``h_hat(j)`` is at least
            ``c_best``: no path through them can be better (the pruning of informed RRT*,
            Gammell et al. 2014, applied to every sampler). It leaves the best cost's
            convergence unchanged and saves most rewiring edges in high dimensions, where
            they cost hundreds of checks each. ``log`` counts ``pruned_samples`` and
            ``pruned_rewires``.
    """

    step_size: float = 0.5
    goal_bias: float = 0.05
    gamma_factor: float = 1.1
    informed: bool = True
    max_iterations: int | None = 5_000
    time_limit_s: float | None = 1.0
    seed: int = 0
    stop_at_first: bool = False
    k_nearest: bool = True
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4
    first_solution: str = "rrt_connect"
    prune: bool = True


FIRST_SOLUTIONS = ("rrt_connect", "rrt_star")


def unit_ball_volume(d: int) -> float:
    """``zeta_d``, the volume of the unit ball in ``d`` dimensions."""
    return math.pi ** (d / 2) / math.gamma(d / 2 + 1)


def informed_sample(
    rng: np.random.Generator,
    start: FloatArray,
    goal: FloatArray,
    c_best: float,
    rotation: FloatArray,
) -> FloatArray:
    """A uniform sample of the prolate hyperspheroid ``|x - start| + |x - goal| <= c_best``."""
    d = start.size
    c_min = float(np.linalg.norm(goal - start))
    radii = np.full(d, math.sqrt(max(c_best**2 - c_min**2, 0.0)) / 2)
    radii[0] = c_best / 2
    x = rng.standard_normal(d)
    x *= rng.random() ** (1.0 / d) / np.linalg.norm(x)  # uniform in the unit ball
    return rotation @ (radii * x) + (start + goal) / 2


def _rotation_to_world(start: FloatArray, goal: FloatArray) -> FloatArray:
    """``C`` with ``C e_1 = (goal - start) / |goal - start|`` (SVD construction of Gammell)."""
    d = start.size
    a1 = (goal - start) / np.linalg.norm(goal - start)
    u, _, vt = np.linalg.svd(np.outer(a1, np.eye(d)[0]))
    diag = np.ones(d)
    diag[-1] = np.linalg.det(u) * np.linalg.det(vt.T)
    return u @ np.diag(diag) @ vt


class _RRTStarTree:
    """Nodes, parents, costs-to-come and children of the tree (grown by doubling)."""

    def __init__(self, root: FloatArray) -> None:
        d = root.size
        self.nodes = np.empty((1024, d))
        self.parents = np.full(1024, -1, dtype=np.int64)
        self.cost = np.zeros(1024)
        self.children: list[list[int]] = [[]]
        self.nodes[0] = root
        self.n = 1

    def add(self, q: FloatArray, parent: int, cost: float) -> int:
        if self.n == len(self.cost):
            size = 2 * self.n
            self.nodes = np.resize(self.nodes, (size, self.nodes.shape[1]))
            self.parents = np.resize(self.parents, size)
            self.cost = np.resize(self.cost, size)
        i = self.n
        self.nodes[i], self.parents[i], self.cost[i] = q, parent, cost
        self.children.append([])
        if parent >= 0:
            self.children[parent].append(i)
        self.n += 1
        return i

    def reparent(self, i: int, parent: int, cost: float) -> None:
        self.children[int(self.parents[i])].remove(i)
        self.parents[i] = parent
        self.children[parent].append(i)
        _propagate(i, cost - self.cost[i], self.cost, self.children)


def rrt_star(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: RRTStarOptions | None = None,
    *,
    objective: OptimizationObjective | None = None,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Plan a short collision-free path from ``start`` to a goal with (informed) RRT*.

    Args:
        space: configuration space with validity checker and local planner.
        start: ``q_start`` (size d).
        goal: one goal configuration (d,), several (k, d) (the path ends at whichever is
            cheaper to reach), or a :class:`GoalRegion` (sampled for the goal bias; every
            tree node inside it ends a candidate path).
        options: planner settings.
        objective: path cost (default: Euclidean :class:`~taskspace.planning.PathLength`;
            on a joint-manifold space the length in its metric, and any objective is taken
            along its geodesics, see :mod:`~taskspace.planning.objectives`); nearest
            neighbours stay in the space's metric, parents and rewiring use its motion costs.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        The best path found within the limits; ``cost`` is its objective cost; ``log``
        holds ``cost_times`` and ``costs`` (the best cost each time it improved),
        ``first_solution_s``, the tree size and ``stopped_by``. Informed sampling is used
        with a single goal configuration and the Euclidean length only.

    Raises:
        PlanningError: start or goal outside the bounds or in collision.
        InvalidInputError: invalid options; ``certify`` on a space without a robot.

    Certified paths: with ``options.certify`` the best path is proven free between its
    checked points by :func:`~taskspace.planning.certify_path`; an uncertified path is
    re-planned with the next seeds (``certify_retries`` times, within the time limit), and
    if none can be certified the result has ``success=False``, status ``UNCERTIFIED`` and
    the failing segment in ``log``.
    """
    opts = options or RRTStarOptions()
    if not opts.certify:
        return _plan(space, start, goal, opts, objective, rng)
    return plan_certified(space, opts, lambda o, r: _plan(space, start, goal, o, objective, rng, r))


def _plan(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: RRTStarOptions,
    objective: OptimizationObjective | None,
    rng: np.random.Generator | None,
    regions: FailedRegions | None = None,
) -> PlannerResult:
    """:func:`rrt_star` without certification.

    ``regions``: the failed regions of earlier certificates (a certified re-plan): every edge
    (RRT-Connect's first path, parents, rewiring, goal edges, the straight line) must be
    certified inside them (:class:`~taskspace.planning.certify.FailedRegions`).
    """

    def motion_valid(q0: FloatArray, q1: FloatArray) -> bool:
        return space.motion_valid(q0, q1) and (regions is None or regions.allows(q0, q1))

    eta = check_positive(opts.step_size, "step_size")
    iterations, limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    if not 0.0 <= opts.goal_bias <= 1.0:
        raise InvalidInputError(f"goal_bias must be in [0, 1], got {opts.goal_bias}")
    check_positive(opts.gamma_factor, "gamma_factor")
    if opts.first_solution not in FIRST_SOLUTIONS:
        raise InvalidInputError(
            f"first_solution must be one of {', '.join(FIRST_SOLUTIONS)}, "
            f"got {opts.first_solution!r}"
        )
    cost_of = space_objective(space, objective)
    rng = rng or np.random.default_rng(check_seed(opts.seed))
    q_start = space.check_endpoint(start, "start")
    goals, region = goal_states(space, goal)
    optimum_bound = optimum_lower_bound(cost_of, q_start, goals, region)
    stopped_by = ""
    d = space.tangent_dim
    bounded = np.ones(space.dim, bool) if space.manifold is None else space.manifold.bounded_mask()
    volume = float(np.prod((space.upper - space.lower)[bounded]))
    k_rrg = opts.gamma_factor * math.e * (1 + 1 / d)
    gamma = (
        opts.gamma_factor * 2 * (1 + 1 / d) ** (1 / d) * (volume / unit_ball_volume(d)) ** (1 / d)
    )
    checks0, edges0 = space.checks, space.edge_checks
    t0 = time.perf_counter()
    deadline = t0 + limit
    budget = Budget(iterations, limit, t0)
    found = edge_case(space, q_start, goals, region, budget)
    if found is not None and regions is not None:
        found = regions.edge_case(found)
    if found is not None:
        return edge_case_result(
            space, found, budget, (checks0, edges0), cost_of, goal_count=len(goals)
        )

    tree = _RRTStarTree(q_start)
    goal_nodes: dict[int, int] = {}  # goal state index -> its tree node
    region_nodes: list[int] = []
    rotation = None
    euclidean = cost_of.is_euclidean_length and space.is_euclidean
    if opts.informed and region is None and len(goals) == 1 and euclidean:
        if np.linalg.norm(goals[0] - q_start) > 0:
            rotation = _rotation_to_world(q_start, goals[0])
    if region is not None and region.contains(q_start):
        region_nodes.append(0)

    def cost_to_go(points: FloatArray) -> FloatArray:
        """Admissible bounds on the cost from each row of ``points`` to a goal (0: a region)."""
        if region is not None or not goals:
            return np.zeros(points.shape[0])
        return np.asarray(
            np.min([cost_of.cost_lower_bounds(points, q_goal) for q_goal in goals], axis=0)
        )

    def best_goal() -> tuple[int, float]:
        candidates = list(goal_nodes.values()) + region_nodes
        if not candidates:
            return -1, math.inf
        i = min(candidates, key=lambda j: tree.cost[j])
        return i, float(tree.cost[i])

    cost_times: list[float] = []
    costs: list[float] = []
    status = PlannerStatus.ITERATION_LIMIT
    it = 0
    pruned_samples = pruned_rewires = 0
    first_by = "rrt_star"
    done = False
    aim = -1
    if opts.first_solution == "rrt_connect" and not region_nodes:
        aim = _first_goal(space, q_start, goals, region, rng)
    if aim >= 0:
        it, seeded = _seed_with_rrt_connect(
            space,
            tree,
            goals[aim],
            cost_of,
            rng,
            iterations,
            deadline - time.perf_counter(),
            regions,
        )
        if seeded >= 0:
            first_by = "rrt_connect"
            goal_nodes[aim] = seeded
            cost_times.append(time.perf_counter() - t0)
            costs.append(float(tree.cost[seeded]))
            if opts.stop_at_first:
                status = PlannerStatus.SOLVED
                done = True
            elif reached_optimum(costs[-1], optimum_bound):
                status = PlannerStatus.SOLVED
                stopped_by = "optimal"  # the cost equals a lower bound of the optimum
                done = True
        elif time.perf_counter() - t0 > limit:
            status = PlannerStatus.TIME_LIMIT
            done = True
    while not done and it < iterations:
        if time.perf_counter() > deadline:  # (also right after RRT-Connect's first path)
            status = PlannerStatus.TIME_LIMIT
            break
        it += 1
        _, c_best = best_goal()
        target = None
        if not math.isfinite(c_best) and rng.random() < opts.goal_bias:
            if region is not None:
                sampled = region_samples(space, region, rng, 1)  # valid and contained
                if sampled:
                    goals.append(sampled[0])
                    target = goals[-1]
            elif goals:
                target = goals[int(rng.integers(len(goals)))]
        if target is None and rotation is not None and math.isfinite(c_best):
            for _ in range(100):  # rejection against the bounds
                candidate = informed_sample(rng, q_start, goals[0], c_best, rotation)
                if space.within_bounds(candidate):
                    target = candidate
                    break
        if target is None:
            target = space.sample_uniform(rng)
        nodes = tree.nodes[: tree.n]
        to_target = space.distances(nodes, target)
        near_i = int(to_target.argmin())
        length = float(to_target[near_i])
        if length < 1e-12:
            continue
        x_new = space.interpolate(nodes[near_i], target, min(1.0, eta / length))[0]
        if math.isfinite(c_best) and opts.prune:
            # f_hat(x_new) = c_hat(start, x_new) + h_hat(x_new) >= c_best: no path through
            # x_new can beat the best one (both bounds admissible): skip it unchecked
            f_hat = cost_of.cost_lower_bounds(q_start, x_new[None, :])[0]
            if f_hat + cost_to_go(x_new[None, :])[0] >= c_best:
                pruned_samples += 1
                continue
        if not space.is_valid(x_new) or time.perf_counter() > deadline:
            continue  # (out of time: the loop ends at its next clock reading)
        if not motion_valid(nodes[near_i], x_new):
            continue
        n = tree.n
        dist = space.distances(nodes, x_new)
        if opts.k_nearest:
            k = min(n, math.ceil(k_rrg * math.log(n + 1)))
            near = np.argpartition(dist, k - 1)[:k] if k < n else np.arange(n)
        else:
            radius = min(gamma * (math.log(n + 1) / (n + 1)) ** (1 / d), eta)
            near = np.flatnonzero(dist <= radius)
        # Choose the parent of least cost-to-come among the neighbours.
        cost = tree.cost
        edge = np.zeros(n)
        candidates = np.union1d(near, [near_i])
        edge[candidates] = cost_of.motion_costs(nodes[candidates], x_new)
        best_parent = near_i
        best_cost = cost[near_i] + edge[near_i]
        parent_bound = best_cost
        if math.isfinite(c_best) and opts.prune:
            # a parent through which x_new cannot lie on a better path is not worth an edge
            # check (near_i, already checked, serves as well)
            parent_bound = min(best_cost, c_best - cost_to_go(x_new[None, :])[0])
        # The clock is read before every edge check of the parent choice and the rewiring
        # (each may be hundreds of checks at high dof): the limit is overrun by one edge at
        # most. The node is added with the parent found so far (near_i is checked).
        late = False
        for j in near[np.argsort(cost[near] + edge[near])]:
            c = cost[j] + edge[j]
            if c >= parent_bound:
                break
            if j == near_i:
                continue
            if time.perf_counter() > deadline:
                late = True
                break
            if motion_valid(nodes[j], x_new):
                best_parent, best_cost = int(j), c
                break
        new = tree.add(x_new, best_parent, float(best_cost))
        # Rewire the neighbours through x_new (the improving ones; once a path exists, only
        # those that could then lie on a better path: c + h_hat(j) < c_best, since every
        # path through j costs at least that).
        through = best_cost + edge[near]
        improves = (through < tree.cost[near] - 1e-12) & (near != best_parent)
        if math.isfinite(c_best) and opts.prune and improves.any():
            useful = through + cost_to_go(tree.nodes[near]) < c_best
            pruned_rewires += int(np.count_nonzero(improves & ~useful))
            improves &= useful
        for j, c in zip(near[improves].tolist(), through[improves].tolist(), strict=True):
            if late:
                break
            if c >= tree.cost[j] - 1e-12:
                continue  # an earlier rewire of this iteration lowered it (its subtree)
            if time.perf_counter() > deadline:
                late = True
                break
            if motion_valid(x_new, tree.nodes[j]):
                tree.reparent(j, new, float(c))
        # Connect to the goals.
        if region is not None and region.contains(x_new):
            region_nodes.append(new)
        for g, q_goal in enumerate(goals):
            if late or space.distance(q_goal, x_new) > eta:
                continue
            to_goal = cost_of.motion_cost(x_new, q_goal)
            node = goal_nodes.get(g, -1)
            if best_cost + to_goal >= (tree.cost[node] if node >= 0 else math.inf):
                continue
            if time.perf_counter() > deadline:
                late = True
                continue
            if motion_valid(x_new, q_goal):
                if node < 0:
                    goal_nodes[g] = tree.add(q_goal, new, best_cost + to_goal)
                else:
                    tree.reparent(node, new, best_cost + to_goal)
        _, c_now = best_goal()
        if math.isfinite(c_now) and (not costs or c_now < costs[-1] - 1e-12):
            cost_times.append(time.perf_counter() - t0)
            costs.append(c_now)
            if opts.stop_at_first:
                status = PlannerStatus.SOLVED
                break
            if reached_optimum(c_now, optimum_bound):
                status = PlannerStatus.SOLVED
                stopped_by = "optimal"  # the cost equals a lower bound of the optimum
                break
    elapsed = time.perf_counter() - t0
    result_tree = Tree(tree.nodes[: tree.n].copy(), tree.parents[: tree.n].copy())
    goal_node, _ = best_goal()
    success = goal_node >= 0
    path = result_tree.path_to(goal_node) if success else np.zeros((0, space.dim))
    log: dict[str, Any] = {
        "tree_size": float(tree.n),
        "first_solution_s": cost_times[0] if cost_times else math.inf,
        "cost_times": cost_times,
        "costs": costs,
        "gamma": gamma,
        "goal_states": float(len(goals)),
        "first_solution_by": first_by,
        "pruned_samples": float(pruned_samples),
        "pruned_rewires": float(pruned_rewires),
        "stopped_by": stopped_by
        or {
            PlannerStatus.TIME_LIMIT: "time",
            PlannerStatus.ITERATION_LIMIT: "iterations",
            PlannerStatus.SOLVED: "first solution",
        }[status],
    }
    return PlannerResult(
        success=success,
        status=PlannerStatus.SOLVED if success else status,
        path=path,
        path_length=result_length(space, path, success),
        cost=float(tree.cost[goal_node]) if success else math.inf,
        iterations=it,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=elapsed,
        trees=[result_tree],
        log=log,
    )


def _first_goal(
    space: ConfigurationSpace,
    q_start: FloatArray,
    goals: list[FloatArray],
    region: Any,
    rng: np.random.Generator,
) -> int:
    """Index in ``goals`` of the goal RRT-Connect aims at first (-1: none).

    With a goal region a valid sample of it is appended to ``goals`` (as the goal bias does).
    """
    if region is None:
        if not goals:
            return -1
        return int(space.distances(np.asarray(goals), q_start).argmin())
    for _ in range(3):
        sampled = region_samples(space, region, rng, 1)  # valid and contained
        if sampled:
            goals.append(sampled[0])
            return len(goals) - 1
    return -1


def _seed_with_rrt_connect(
    space: ConfigurationSpace,
    tree: _RRTStarTree,
    q_goal: FloatArray,
    cost_of: OptimizationObjective,
    rng: np.random.Generator,
    iterations: int,
    limit: float,
    regions: FailedRegions | None = None,
) -> tuple[int, int]:
    """RRT-Connect's path from the root to ``q_goal`` as a branch of ``tree``.

    ``limit`` is the time left [s] (``math.inf``: none): RRT-Connect gets exactly that
    budget, and is not called when it is not positive (RRT-Connect's own overrun, one of
    its iterations in Python or a few checks in the compiled kernel, is the only one).

    Returns the iterations RRT-Connect used and the tree node of ``q_goal`` (-1 when
    RRT-Connect found no path within the limits). Every edge of RRT-Connect's path is free
    at the space's resolution, as RRT*'s own edges are, and certified inside ``regions``.
    """
    from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
    from taskspace.planning.rrt_connect import _plan as rrt_connect_plan

    if iterations <= 0 or limit <= 0.0:  # no time left: not even its endpoint checks
        return 0, -1
    options = RRTConnectOptions(
        max_iterations=iterations if iterations < 2**62 else None,
        time_limit_s=limit if math.isfinite(limit) else None,
        seed=int(rng.integers(2**31)),
    )
    if regions is None:
        result = rrt_connect(space, tree.nodes[0], q_goal, options)
    else:  # a certified re-plan: rrt_connect with the failed regions
        result = rrt_connect_plan(
            space, tree.nodes[0], q_goal, options, None, time.perf_counter(), regions
        )
    used = min(int(result.iterations), iterations)
    path = result.path
    if not result.success or path.shape[0] < 2 or space.distance(path[-1], q_goal) > 1e-9:
        return used, -1
    node = 0
    steps = cost_of.motion_costs(path[:-1], path[1:]) if path.shape[0] > 1 else np.zeros(0)
    for q, step in zip(path[1:-1], steps[:-1], strict=True):
        node = tree.add(q, node, float(tree.cost[node] + step))
    node = tree.add(q_goal, node, float(tree.cost[node] + steps[-1]))
    return max(used, 1), node


def _propagate(root: int, delta: float, cost: FloatArray, children: list[list[int]]) -> None:
    """Add ``delta`` to the cost-to-come of ``root`` and of its whole subtree."""
    stack = [root]
    while stack:
        i = stack.pop()
        cost[i] += delta
        stack.extend(children[i])


def interpolate(path: Any, resolution: float) -> FloatArray:
    """The path with waypoints inserted every ``resolution`` [rad or m] at most.

    Consecutive waypoints of the result are at most ``resolution`` apart (Euclidean); the
    original waypoints are kept. For a space on a joint manifold (continuous joints, planar or
    floating bases) use :meth:`ConfigurationSpace.interpolate_path`, which interpolates on
    the manifold.

    Args:
        path: waypoints, shape (m, d), one per row. A 1-D array is refused (three values may
            be three waypoints of a 1-D space or one waypoint): give ``[[0], [1], [2]]`` or
            ``[[0, 1, 2]]``, or use :meth:`ConfigurationSpace.interpolate_path`, which knows
            the dimension.
        resolution: the largest distance between consecutive waypoints [rad or m].

    Raises:
        InvalidInputError: not a finite (m, d) path (a 1-D one), a resolution <= 0, or one so
            small that the path would take more than 2 GiB.
    """
    arr = as_path(path, None)
    step = check_positive(resolution, "resolution")
    pairs = list(itertools.pairwise(arr))
    lengths = [float(np.linalg.norm(b - a)) for a, b in pairs]
    out = [arr[:1]]
    for (a, b), k in zip(pairs, interpolated_counts(lengths, step, arr.shape[1])):
        t = np.arange(1, k + 1)[:, None] / k
        out.append(a + t * (b - a))
    return np.vstack(out)
