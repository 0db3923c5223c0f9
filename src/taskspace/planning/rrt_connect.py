"""Bidirectional RRT: RRT-Connect (slide 3:42; Kuffner and LaValle, ICRA 2000).

Two trees grow from ``q_start`` and ``q_goal``; they swap roles every iteration::

    T_a = {q_start}, T_b = {q_goal}
    for i = 0..n:
        q_target <- random sample from Q
        EXTEND(T_a, q_target):  q_near <- nearest(T_a, q_target)
                                q_new <- q_near + min(alpha, |q_target - q_near|)
                                                  * unit(q_target - q_near)
                                add q_new if the segment q_near -> q_new is in Q_free
        if q_new was added:
            CONNECT(T_b, q_new): repeat EXTEND(T_b, q_new) until q_new is reached (path found)
                                 or the extension is blocked
        swap(T_a, T_b)

"Choose q_new of T_1 as q_target of T_2" (slide 3:42) is the CONNECT step. Since every
EXTEND of CONNECT moves along the same straight line ``q_near -> q_new``, the whole CONNECT
is one line of steps of length ``alpha``; its points are sent to the checker in ONE call, step
after step (each step: its end point first, then its interior points in bisection order, as
OMPL's ``DiscreteMotionValidator`` does), and the call stops at the first collision: every
step before it is free and becomes a node, as in the step-by-step loop, with the same
collision checks.

Lazy fine checking (coarse-to-fine, in the spirit of SBL, Sanchez and Latombe 2001): tree
edges are checked eagerly only at a coarse resolution ``delta_c`` (nodes are always checked).
When the trees connect, the interior points at the full resolution ``delta`` of the edges of
the candidate path (and only those) are checked, in one call, edge after edge, each edge's in
increasing order (neighbouring configurations in one batch of the compiled sphere checks,
which then prune more: which edge collides first does not depend on the order within an
edge, only the count of checks before it does). If one is in collision, that
edge's child and its subtree are removed and the search goes on; otherwise the path is
returned. Every edge of a returned path is therefore free at resolution ``delta``, the same
guarantee as checking every tree edge at ``delta``, but the fine points of the many edges that
never lie on the solution are not checked. ``coarse_resolution=None`` gives the classic eager
algorithm. Nearest neighbours: :class:`GrowingNearest`.

Trapped trees: in pick problems the goal often lies in a tight region (fingers around an
object in a shelf) from which steps towards uniform samples nearly always collide; the goal
tree then stays at a few nodes while the start tree grows to thousands. When a tree has fewer
than a quarter of the other's nodes, its target is, with probability ``local_sampling``, drawn
around one of its own nodes (a Gaussian of standard deviation ``local_sigma``), which lets it
grow out of the region. Such a tree also takes the other tree's turn with probability
``trapped_priority`` (the other tree then CONNECTs towards its new node): the free tree, whose
EXTEND nearly always succeeds, would otherwise spend most of the collision checks on growing.

Compiled planner: ``RRTConnectOptions.native`` (default) runs this algorithm in C++
(``taskspace/_native/planning_kernel.cpp``, compiled when taskspace is pip-installed)
when the space's checker is a :class:`~taskspace.planning.CollisionChecker`; the collision
checks call Pinocchio and coal directly. Its random stream is its own (seeded by ``seed`` or
by the ``rng`` passed), so its trees differ from this module's; its paths carry the same
guarantee. Options are validated here before the call; the kernel checks the start and goal
(finite, inside the bounds, free for the exact checker) and computes the path's length in the
same call (a failed endpoint is then re-checked here for the error message), so a plan is one
kernel call and a few Python objects.

Sphere checkers (``RRTConnectOptions.checker``, compiled planner only): the robot's
conservative spheres (:meth:`~taskspace.planning.CollisionChecker.sphere_model`) checked per
link, per object and per sphere against the obstacles' primitives and the self pairs'
spheres, with kinematics only (no geometry placements), see the kernel's header.
``"spheres"`` runs coal's exact narrow phase where spheres touch: the same answers as
``"mesh"`` (the same trees and paths, tested). ``"spheres_only"`` stops at the spheres and is
conservative: some free configurations are refused, so tight goals (a grasp between shelf
walls) become hard; it therefore goes on with ``"spheres"`` after ``fallback_iterations``
iterations without a path, inside the kernel (the trees stay: their nodes and coarse points
are free for the spheres, hence free), and says so in ``log["spheres_fallback"]``.
Validation of the returned path: the lazy fine pass uses the exact checker (or ``"spheres"``
with ``RRTConnectOptions.validator="spheres"``, the same answers at a lower cost), the
endpoints are checked exactly, the nodes and coarse points by the sphere checker. The sphere
model carries a proved volume certificate (:func:`~taskspace.planning.sphere_model.certify_cover`:
each link's convex hull lies 10 um inside its spheres), so a sphere checker's "free" implies
the exact checker's "free" (the proof is in the kernel, ``RRTConnect::recheck``; tested
against Pinocchio near contact): every point of the path at the resolution is validated
once, with no exact re-check (``log["exact_recheck_checks"]`` is 0). Spheres without the
certificate (set by hand on the kernel) get the exact re-check of the nodes and coarse
points (all points with ``validator="spheres"``).
The sphere checkers check an edge's points in batches of four (kinematics in
vector lanes, then the tests point by point with early exit).

``checker="clearance"`` (#22 items 4 and 5): ``"spheres_only"`` that certifies whole edges
instead of checking points. A sphere check returns the clearance of every sphere (to the
obstacles, and to the spheres of the self pairs), and a per-link bound on how far a sphere
moves per radian of each upstream joint (its distance to the joint's axis, bounded over every
configuration from the joint placements) turns it into an interval of the edge that is free
for the spheres (conservative advancement). Each edge is covered by such intervals (its end
point first, then the midpoints of the gaps); an edge whose intervals shrink below 1e-3 of the
resolution is refused (conservative). The edges are then free everywhere, not only at their
points: no lazy fine pass, and with the sphere model's volume certificate a returned path is
free for the meshes everywhere along it (``log["path_certified"]`` is 1; 0 after a fallback to
``"spheres"``, whose edges are checked at points).

Measured times, success rates and check counts (against OMPL and earlier versions) are in
``benchmarks/suites/planning.py`` and the README's benchmark table.

Thread safety: :class:`RRTConnectOptions` is immutable; the planners keep their state local to the
call apart from the configuration space (one space per thread) and generator they are given.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from taskspace._validation import check_count, check_positive, check_seed
from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.certify import FailedRegions, plan_certified
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    FloatArray,
    IntArray,
    nested_orders,
)
from taskspace.planning.goals import REGION_FIRST_ATTEMPTS, goal_states, is_goal_set, region_samples
from taskspace.planning.limits import Budget, limit_log, planner_limits, result_length
from taskspace.planning.locked_joints import LockedJointChecker
from taskspace.planning.nearest import GrowingNearest
from taskspace.planning.planner_result import PlannerResult, PlannerStatus, Tree

logger = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class RRTConnectOptions:
    """Settings of :func:`rrt_connect`.

    Attributes:
        step_size: extension step ``alpha`` [rad or m] (slide 3:39).
        coarse_resolution: eager edge-check resolution ``delta_c`` [rad or m]; the full
            resolution ``delta`` of the space is checked only on candidate paths. ``None``
            (or a value <= ``delta``) checks every tree edge at ``delta`` (classic RRT-Connect).
        partial_extend: EXTEND checks the step's coarse points in order and keeps the last
            free one (instead of all-or-nothing, end point first); measured worse on the
            MotionBenchMaker Panda problems, off by default.
        local_sampling: probability ``p`` of drawing the target of a *trapped* tree (fewer
            than a quarter of the other tree's nodes: typically the goal tree in a tight grasp
            region) as ``q_i + sigma N(0, I)`` around one of its own random nodes ``q_i``
            instead of uniformly; uniform samples keep probability ``>= 1 - p``.
        local_sigma: ``sigma`` of those local targets [rad or m].
        trapped_priority: probability that a trapped tree (as above) takes the other tree's
            turn: it EXTENDs and the other tree CONNECTs towards its new node; 0 alternates
            the trees as the classic algorithm.
        max_iterations: number of samples ``n`` (an integer >= 0; values beyond ``2**63 - 1``
            are that; ``None`` with a finite time limit: :mod:`taskspace.planning.limits`).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = no limit; NaN is
            refused).
        seed: random seed (an integer >= 0) used when no ``rng`` is passed; the compiled
            planner uses it modulo ``2**64``.
        native: run the compiled planner (``taskspace/_native/planning_kernel.cpp``: the same
            algorithm, with its own random stream) when it is built and the space's checker
            is a :class:`~taskspace.planning.CollisionChecker`; otherwise, or with
            ``partial_extend``, this module's Python implementation runs.
        certify: prove the returned path free between its checked points (see
            :func:`rrt_connect`); needs a space built on a robot.
        certify_retries: re-plans (next seeds) after an uncertified path; a re-plan accepts a
            motion near a spot where an earlier certificate failed only if it is certified
            there (:class:`~taskspace.planning.certify.FailedRegions`).
        certify_tolerance: the least robot-obstacle (and self) distance [m] along the path
            counted as free by the certification.
        checker: collision test of the compiled planner (see :data:`CHECKERS`): ``"mesh"``
            (the exact check of every configuration), ``"spheres"`` (the robot's conservative
            spheres, :meth:`~taskspace.planning.CollisionChecker.sphere_model`, as the broad
            phase and coal's exact narrow phase for the pairs whose spheres touch: the same
            answers) or ``"spheres_only"`` (a pair whose spheres touch counts as colliding:
            conservative, may miss passages narrower than the spheres' margin). With the
            sphere checkers every point of the returned path at the full resolution is
            validated: by the exact checker (endpoints, the lazy fine pass) or by the sphere
            checker, whose "free" implies the exact checker's (the sphere model's proved
            volume certificate); without the certificate the nodes and coarse points are
            re-checked exactly and a path that fails is dropped and the problem planned again
            with ``"mesh"`` (``log["sphere_recheck_failed"]``). ``"clearance"``:
            ``"spheres_only"`` with every edge certified free by the spheres' clearance and a
            bound on their motion (see the module docstring), not only its points; it falls
            back to ``"spheres"`` as ``"spheres_only"`` does. The Python planner ignores it
            (exact checks).
        fallback_iterations: with ``checker="spheres_only"``: after this many iterations
            without a path, the plan goes on with ``"spheres"`` (the spheres' margin may close
            a narrow passage; the trees stay, their nodes are free).
            ``log["spheres_fallback"]`` is 1 when it happened and
            ``log["spheres_fallback_iteration"]`` the iteration (-1: none). ``None``: never.
        validator: with a sphere checker, the checker of the lazy fine pass (see
            :data:`VALIDATORS`): ``"mesh"`` (default: the exact
            mesh checker, independent of the sphere model) or ``"spheres"`` (the spheres, then
            coal's exact narrow phase where they touch: the same answers, tested against
            Pinocchio's ``computeCollisions``, at a lower cost per point; where no spheres
            touch, "free" rests on the sphere model's proved volume certificate) for the lazy
            fine pass. Ignored with ``checker="mesh"``.
    """

    step_size: float = 0.5
    coarse_resolution: float | None = 0.15
    partial_extend: bool = False
    local_sampling: float = 0.5
    local_sigma: float = 0.5
    trapped_priority: float = 0.75
    max_iterations: int | None = 100_000
    time_limit_s: float | None = 1.0
    seed: int = 0
    native: bool = True
    certify: bool = False
    certify_retries: int = 2
    certify_tolerance: float = 1e-4
    checker: str = "mesh"
    fallback_iterations: int | None = 200
    validator: str = "mesh"


CHECKERS = ("mesh", "spheres", "spheres_only", "clearance")
"""Values of :attr:`RRTConnectOptions.checker` (codes 0-3 of the compiled kernel)."""

VALIDATORS = ("mesh", "spheres")
"""Values of :attr:`RRTConnectOptions.validator` (codes 0, 1 of the compiled kernel)."""

_DEFAULT_OPTIONS = RRTConnectOptions()
"""The options of :func:`rrt_connect` called without (immutable: one object for every call)."""


class _GrowingTree:
    """Nodes (vectorized nearest), parent indices and the edge-check state of each node.

    ``segments[i]`` is the number ``n`` of full-resolution segments of the edge
    ``parent -> i``; ``pending[i]`` is True while its fine points have not been checked.
    """

    def __init__(self, root: FloatArray, metric: Any = None) -> None:
        self.nn = GrowingNearest(root.size, metric=metric)
        self.nn.add(root)
        self.parents: list[int] = [-1]
        self.segments: list[int] = [0]
        self.pending: list[bool] = [False]
        self.removed: dict[int, FloatArray] = {}

    def add(self, q: FloatArray, parent: int, segments: int = 0, pending: bool = False) -> int:
        self.parents.append(parent)
        self.segments.append(segments)
        self.pending.append(pending)
        return self.nn.add(q)

    def path_indices(self, index: int) -> list[int]:
        """Node indices from ``index`` up to the root."""
        out = [index]
        parents = self.parents
        while parents[out[-1]] >= 0:
            out.append(parents[out[-1]])
        return out

    def remove_subtree(self, index: int) -> int:
        """Remove node ``index`` and its descendants (children have larger indices)."""
        dead = {index}
        parents = self.parents
        for i in range(index + 1, len(parents)):
            if parents[i] in dead:
                dead.add(i)
        ids = sorted(dead)
        points = self.nn.points
        for i in ids:
            self.removed[i] = points[i].copy()
            parents[i] = -1
            self.pending[i] = False
        self.nn.disable(ids)
        return len(ids)

    def freeze(self) -> Tree:
        nodes = self.nn.points.copy()
        for i, q in self.removed.items():
            nodes[i] = q
        return Tree(nodes=nodes, parents=np.asarray(self.parents, dtype=np.int64))


def _steer(q_near: FloatArray, q_target: FloatArray, dist: float, alpha: float) -> FloatArray:
    """``q_near + alpha / |q_target - q_near| (q_target - q_near)``, or ``q_target`` if closer."""
    if dist <= alpha:
        return q_target.copy()
    return q_near + (alpha / dist) * (q_target - q_near)


class _LinePlanner:
    """Check order of straight lines cut into steps of length ``alpha`` (coarse pass).

    For a step of length ``L``: ``n = ceil(L / delta)`` full-resolution segments; the coarse
    pass checks the step's end point, then the interior points ``k / n`` with ``k`` a multiple
    of ``stride = floor(delta_c / delta)`` in bisection order (see :func:`nested_orders`).
    Patterns are cached: planning a line costs a few numpy operations.
    """

    def __init__(self, alpha: float, delta: float, delta_c: float) -> None:
        self.alpha = alpha
        self.delta = delta
        self.stride = max(1, math.floor(delta_c / delta + 1e-9))
        self.lazy = self.stride > 1
        self._patterns: dict[int, FloatArray] = {}
        self._full: dict[int, tuple[FloatArray, IntArray]] = {}
        self._sequences: dict[int, tuple[FloatArray, IntArray]] = {}
        self.full_n = self.segments(alpha)
        self._full_u: FloatArray | None = None

    @property
    def full_u(self) -> FloatArray:
        """The pattern of a full step, made at the first line longer than ``alpha``.

        Not before: a step far longer than any line (``step_size=1e9`` for "no step limit")
        would make a pattern of ``alpha / delta`` points that no line uses.
        """
        u = self._full_u
        if u is None:
            u = self._full_u = self.pattern(self.full_n)
        return u

    def segments(self, length: float) -> int:
        return max(1, math.ceil(length / self.delta - 1e-12))

    def pattern(self, n: int) -> FloatArray:
        """Fractions of one step: end point, then the coarse interior in bisection order."""
        u = self._patterns.get(n)
        if u is None:
            coarse, _ = nested_orders(n, self.stride)
            u = np.concatenate([[1.0], coarse / n])
            self._patterns[n] = u
        return u

    def sequence(self, n: int) -> tuple[FloatArray, IntArray]:
        """Coarse points of one step of ``n`` segments in order along it (end point last).

        Returns the fractions and the grid index of each point.
        """
        got = self._sequences.get(n)
        if got is None:
            n_coarse = max(1, -(-n // self.stride))
            grid = np.append(np.arange(1, n_coarse) * self.stride, n).astype(np.int64)
            got = (grid / n, grid)
            self._sequences[n] = got
        return got

    def full_steps(self, count: int) -> tuple[FloatArray, IntArray]:
        """Distances along the line [rad or m] and step indices of ``count`` full steps."""
        got = self._full.get(count)
        if got is None:
            u = self.full_u
            s = (np.arange(count)[:, None] + u[None, :]).ravel() * self.alpha
            got = (s, np.repeat(np.arange(count), u.size))
            if len(self._full) < 256:
                self._full[count] = got
        return got

    def plan(
        self, dist: float, max_steps: int, end_known_valid: bool
    ) -> tuple[FloatArray, IntArray | None, list[float], list[int]]:
        """Fractions ``t`` of the points to check (in order), their step, step ends and sizes.

        Args:
            dist: line length [rad or m].
            max_steps: largest number of steps (1 for EXTEND).
            end_known_valid: the line's end point is a known free node (CONNECT).

        Returns:
            ``(t, step_of_point, ends, n_segments)``; ``step_of_point`` is None for one step.
        """
        alpha = self.alpha
        whole = max(1, math.ceil(dist / alpha - 1e-12))
        if whole > max_steps:
            n_full = max_steps
            s, steps = self.full_steps(n_full)
            ends = [(k + 1) * alpha / dist for k in range(n_full)]
            return s / dist, steps if n_full > 1 else None, ends, [self.full_n] * n_full
        n_full = whole - 1
        last = dist - n_full * alpha
        n_last = self.segments(last)
        u_last = self.pattern(n_last)
        if end_known_valid:
            u_last = u_last[1:]
        if n_full == 0:
            return u_last, None, [1.0], [n_last]
        s, steps = self.full_steps(n_full)
        t = np.concatenate([s / dist, (n_full * alpha + u_last * last) / dist])
        steps = np.concatenate([steps, np.full(u_last.size, n_full)])
        ends = [(k + 1) * alpha / dist for k in range(n_full)] + [1.0]
        return t, steps, ends, [self.full_n] * n_full + [n_last]


def _grow(
    space: ConfigurationSpace,
    tree: _GrowingTree,
    lines: _LinePlanner,
    i_near: int,
    target: FloatArray,
    dist: float,
    max_steps: int,
    end_known_valid: bool,
    budget: Budget,
    regions: FailedRegions | None = None,
) -> tuple[int, bool, bool]:
    """Steps from node ``i_near`` towards ``target``.

    The steps are checked one after the other (one checker call each, the clock read before
    each: :meth:`Budget.first_invalid`); every step checked free becomes a node. With
    ``regions`` (a re-plan after failed certificates), the steps after the first one
    :meth:`FailedRegions.allows` refuses are out too.

    Returns:
        ``(last node added, target reached, out of time)``; the last node is ``i_near`` when
        the first step is blocked (or the time ran out before it).
    """
    q0 = tree.nn.points[i_near].copy()
    t, steps, ends, n_segments = lines.plan(dist, max_steps, end_known_valid)
    # one group per step: the full steps have lines.full_u.size points each, the last step
    # as many or fewer
    bounds = [t.size]  # one step (no full step, or EXTEND's one)
    if steps is not None:
        bounds = [*range(lines.full_u.size, t.size, lines.full_u.size), t.size]
    bad, stop = budget.first_invalid(space.first_invalid, space.interpolate(q0, target, t), bounds)
    late = bad < 0 and stop < t.size
    if bad < 0 and not late:
        n_ok = len(ends)
    else:  # the step of the first point invalid or not checked, and those after it, are out
        n_ok = 0 if steps is None else int(steps[stop])
    parent = i_near
    lazy = lines.lazy
    q_prev = q0
    for k in range(n_ok):
        q = target.copy() if ends[k] == 1.0 else space.interpolate(q0, target, ends[k])[0]
        if regions is not None and not regions.allows(q_prev, q):
            return parent, False, late
        parent = tree.add(q, parent, n_segments[k], lazy)
        q_prev = q
    reached = n_ok == len(ends) and ends[-1] == 1.0
    return parent, reached, late


def _extend(
    space: ConfigurationSpace,
    tree: _GrowingTree,
    lines: _LinePlanner,
    q_rand: FloatArray,
    partial: bool,
    budget: Budget,
    regions: FailedRegions | None = None,
) -> int:
    """EXTEND(T, q_rand): one step of length <= alpha from the nearest node; new node or -1.

    Default: the step's end point is checked first, then its coarse interior (OMPL's order);
    with ``partial`` the coarse points are checked in order along the step and the last free
    one becomes the new node. The clock is read before the step's check: :data:`_LATE` when
    the deadline has passed (nothing checked, no node). With ``regions``, a step
    :meth:`FailedRegions.allows` refuses is blocked (-1).
    """
    i_near, dist = tree.nn.nearest(q_rand)
    if dist == 0.0:
        return -1
    space.edge_checks += 1
    q_near = tree.nn.points[i_near]
    alpha = lines.alpha
    n_seg = lines.full_n if dist > alpha else lines.segments(dist)
    step = min(1.0, alpha / dist)
    if partial:
        u, grid = lines.sequence(n_seg)
        points = space.interpolate(q_near, q_rand, u * step)
        if budget.out_of_time():
            return _LATE
        bad = space.checker.first_invalid(points)
        if bad == 0:
            return -1
        if bad > 0:
            q_new = points[bad - 1].copy()
            if regions is not None and not regions.allows(q_near, q_new):
                return -1
            return tree.add(q_new, i_near, int(grid[bad - 1]), lines.lazy)
    else:
        points = space.interpolate(q_near, q_rand, lines.pattern(n_seg) * step)
        if budget.out_of_time():
            return _LATE
        if space.checker.first_invalid(points) >= 0:
            return -1
    q_new = points[0 if not partial else -1].copy() if dist > alpha else q_rand.copy()
    if regions is not None and not regions.allows(q_near, q_new):
        return -1
    return tree.add(q_new, i_near, n_seg, lines.lazy)


def _verify(
    space: ConfigurationSpace,
    trees: list[tuple[_GrowingTree, int]],
    stride: int,
    budget: Budget,
) -> tuple[bool, int, bool]:
    """Check the pending fine points of the edges on the root paths of the given leaves.

    Edges are checked tree after tree, from the root outwards: edges near the roots (the tight
    start and goal regions of manipulation problems) are where the coarse pass misses thin
    obstacles most often, and once verified they serve every later candidate path.

    Each edge's fine points are one checker call, the clock read before each
    (:meth:`Budget.first_invalid`).

    Returns ``(all free, nodes removed, out of time)``; on a collision the child of the first
    colliding edge and its subtree are removed from its tree, the edges checked before it are
    marked; when the time runs out, the edges checked in full are marked (the others stay
    pending) and ``all free`` is False.
    """
    edges: list[tuple[_GrowingTree, int]] = []
    chunks: list[FloatArray] = []
    owner: list[int] = []
    for tree, leaf in trees:
        points = tree.nn.points
        for i in tree.path_indices(leaf)[::-1]:
            if not tree.pending[i]:
                continue
            n = tree.segments[i]
            _, fine = nested_orders(n, stride)
            if fine.size:
                q0, q1 = points[tree.parents[i]], points[i]
                # in increasing order along the edge, as the compiled planner (which edge
                # collides first does not depend on the order within an edge)
                chunks.append(space.interpolate(q0, q1, np.sort(fine) / n))
                owner.append(fine.size)
            else:
                owner.append(0)
            edges.append((tree, i))
    if not edges:
        return True, 0, False
    cum = np.cumsum(np.asarray(owner))
    total = int(cum[-1])
    bad, stop = (
        budget.first_invalid(space.first_invalid, np.vstack(chunks), cum.tolist())
        if chunks
        else (-1, 0)
    )
    if bad < 0 and stop == total:
        for tree, i in edges:
            tree.pending[i] = False
        return True, 0, False
    # the edges before the one that holds row `stop` (invalid or not checked) are free
    failing = int(np.searchsorted(cum, stop, side="right"))
    if bad < 0:  # out of time: only the edges checked in full are marked
        for tree, i in edges[:failing]:
            tree.pending[i] = False
        return False, 0, True
    for tree, i in edges[:failing]:
        tree.pending[i] = False
    tree, i = edges[failing]
    return False, tree.remove_subtree(i), False


def _native_kernel(space: ConfigurationSpace, opts: RRTConnectOptions) -> Any:
    """The compiled checker of the space if the compiled planner can run, else ``None``.

    A locked-joint space is planned by the kernel of its reduced model and geometry
    (:meth:`~taskspace.planning.LockedJointChecker.native_kernel`) with the exact checker
    (its sphere checkers are not built for the reduced geometry).
    """
    if not opts.native or opts.partial_extend:
        return None
    checker = space.checker
    if type(checker) is LockedJointChecker:
        return checker.native_kernel() if space.is_euclidean else None
    if type(checker) is not CollisionChecker:
        return None
    if not space.is_euclidean:  # the compiled planner moves along straight lines in R^d
        return None
    if opts.checker != "mesh":
        return checker.sphere_kernel()
    return checker.native_kernel()


_NATIVE_STATUS = (PlannerStatus.SOLVED, PlannerStatus.TIME_LIMIT, PlannerStatus.ITERATION_LIMIT)
_SOLVED = PlannerStatus.SOLVED  # (an Enum class attribute costs 0.1 us)
_NATIVE_STOPPED_BY = tuple(limit_log(status, 0.0, 0.0)["stopped_by"] for status in _NATIVE_STATUS)
""":func:`~taskspace.planning.limits.limit_log`'s ``stopped_by`` of each kernel status code."""
_START_INVALID, _GOAL_INVALID = 3, 4  # the kernel's codes for an invalid start or goal
_SEED_MASK = (1 << 64) - 1
_LONG_MAX = (1 << 63) - 1  # the kernel's iteration counts are C longs
# A line of the space is cut into at most diameter / min(alpha, delta) steps or checks.
_MAX_LINE_PIECES = float(1 << 30)


def _rrt_connect_native(
    space: ConfigurationSpace,
    kernel: Any,
    checker: int,
    q_start: FloatArray,
    q_goal: FloatArray,
    opts: RRTConnectOptions,
    settings: _Settings,
    bounds: tuple[FloatArray, FloatArray, float],
    delta: float,
    delta_c: float,
    seed: int,
    t0: float,
    prior_checks: int,
    in_kernel: tuple[Any, ...] | None = None,
    regions: FailedRegions | None = None,
) -> PlannerResult:
    """:func:`rrt_connect` by the compiled kernel (options already validated).

    The kernel validates the endpoints (finite, inside the bounds, free for the exact checker)
    before it plans; when one is not, :meth:`ConfigurationSpace.check_endpoint` runs on it
    and raises the error with the reason (the out-of-bounds coordinates, the colliding pairs).

    Args:
        space: configuration space whose checker is a ``CollisionChecker``.
        kernel: that checker's compiled kernel.
        checker: the kernel's collision checker (index in :data:`CHECKERS`).
        q_start: start as a float vector of size d (:meth:`ConfigurationSpace.endpoint_vector`).
        q_goal: goal, as ``q_start``.
        opts: planner settings.
        settings: ``opts`` validated (:func:`_validate`).
        bounds: the space's bounds (:meth:`ConfigurationSpace.bounds_diameter`).
        delta: the space's resolution [rad or m].
        delta_c: the coarse resolution [rad or m].
        seed: seed of the kernel's random generator (>= 0).
        t0: ``time.perf_counter()`` at the call of :func:`rrt_connect` [s].
        prior_checks: collision checks of this call before this plan (a first plan's, for
            its re-plan), added to the result's.
        in_kernel: ``regions.kernel_regions()`` (``None``: no failed regions).
        regions: the failed regions, whose counts of certified and refused edge parts the
            kernel's are added to.
    """
    module = _KERNEL_MODULE[0] if _KERNEL_MODULE else _kernel_module()
    remaining = -1.0  # the kernel's "no limit"
    if settings.time_limit != _INF:
        remaining = settings.time_limit - (time.perf_counter() - t0)
        if not remaining > 0.0:  # max(0.0, remaining)
            remaining = 0.0
    alpha, diameter = settings.alpha, bounds[2]
    kernel_checks0 = kernel.checks
    try:
        out = module.rrt_connect(  # positional, usual types: the kernel's fast entry
            kernel,
            q_start,
            q_goal,
            bounds[0],  # lower
            bounds[1],  # upper
            # a step longer than the bounds' diameter (1e9 for "no step limit", as OMPL's
            # range) is the diameter: no line of the box is longer, so the trees are the same,
            # and the kernel's count of the checks of a full step stays finite
            diameter if diameter < alpha else alpha,  # min(alpha, diameter)
            delta,
            delta_c,
            opts.local_sampling,
            opts.local_sigma,
            opts.trapped_priority,
            settings.max_iterations,
            remaining,
            seed & _SEED_MASK,
            checker,  # collision_checker
            settings.fallback,  # fallback_iterations
            settings.validator,  # validator
            in_kernel,  # regions
        )
    except BaseException:  # also after Ctrl-C: the checks the kernel made are counted
        space.checker.checks += int(kernel.checks - kernel_checks0)
        raise
    (status_code, path, iterations, edges, checks, start_tree, goal_tree, length, region_counts,
     log) = out  # fmt: skip
    space.checker.checks += checks  # the plan's collision checks
    if regions is not None:
        regions.certifications += region_counts[0]
        regions.rejections += region_counts[1]
    if status_code >= _START_INVALID:
        _raise_endpoint(space, q_start, q_goal, status_code)
    space.edge_checks += edges
    status = _NATIVE_STATUS[status_code]
    # the kernel's arrays: nodes (n, d) float64, parents (n,) int64
    trees = [Tree(*start_tree), Tree(*goal_tree)]
    dt = time.perf_counter() - t0
    success = status is _SOLVED
    # the kernel's log (a new dict, keys _NATIVE_LOG_KEYS in order) holds None for
    # limit_log(status, length, dt)'s fields: written out here (length and dt are floats)
    log["stopped_by"] = _NATIVE_STOPPED_BY[status_code]
    if success:
        log["costs"] = [length]
        log["cost_times"] = [dt]
    else:
        log["costs"] = []
        log["cost_times"] = []
    if logger.isEnabledFor(logging.DEBUG):
        logger.debug(
            "rrt_connect (native) %s in %.3f s, %d iterations, %d+%d nodes, %d lazy rejections",
            status.value,
            dt,
            iterations,
            trees[0].size,
            trees[1].size,
            log["lazy_rejections"],
        )
    if success:
        return PlannerResult(  # positional arguments: 0.7 us less than keywords
            True, status, path, length, iterations, prior_checks + checks, edges, dt, trees, log
        )
    empty = np.empty((0, space.dim))
    return PlannerResult(
        False, status, empty, math.inf, iterations, prior_checks + checks, edges, dt, trees, log
    )


_NATIVE_LOG_KEYS = (
    "start_tree_nodes",
    "goal_tree_nodes",
    "lazy_rejections",
    "nodes_removed",
    "trapped_turns",
    "native",
    "checker",
    "validator",
    "exact_recheck_checks",
    "sphere_recheck_failed",
    "spheres_fallback",
    "spheres_fallback_iteration",
    "path_certified",
    "stopped_by",
    "costs",
    "cost_times",
    "kernel_run_us",
    "kernel_endpoints_us",
    "kernel_line_us",
    "kernel_nearest_us",
    "kernel_fine_pass_us",
    "kernel_recheck_us",
)
"""The keys of the compiled plan's log, in order (the kernel's ``RRT_CONNECT_LOG_KEYS``): the
kernel's numbers (floats) with :func:`~taskspace.planning.limits.limit_log`'s three fields
(``stopped_by``, ``costs``, ``cost_times``: ``None`` in the kernel's dict, set here)."""


_KERNEL_MODULE: list[Any] = []
"""The compiled module of the planner, once :func:`_kernel_module` has loaded it."""


def _kernel_module() -> Any:
    """``taskspace._native.planning_kernel()``, kept in :data:`_KERNEL_MODULE`."""
    from taskspace._native import planning_kernel

    module = planning_kernel()
    assert module is not None  # a kernel exists, so does its module
    _KERNEL_MODULE.append(module)
    return module


def _raise_endpoint(space: ConfigurationSpace, q_start: Any, q_goal: Any, code: int) -> None:
    """Raise the error of the endpoint the kernel refused (code 3: start, 4: goal)."""
    space.check_endpoint(q_start, "start")  # raises if the start is the invalid one
    if code == _GOAL_INVALID:
        space.check_endpoint(q_goal, "goal")
    name = "start" if code == _START_INVALID else "goal"
    raise PlanningError(  # the checks disagree (a configuration grazing an obstacle)
        f"{name} is not finite, outside the joint limits or in collision for the compiled checker"
    )


def rrt_connect(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    options: RRTConnectOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
) -> PlannerResult:
    """Plan a collision-free path with RRT-Connect (slide 3:42).

    Every edge of the returned path is free at the space's resolution ``delta``
    (``space.edge.resolution``); tree edges are checked at ``coarse_resolution`` until they
    lie on a candidate path (see the module docstring).

    Args:
        space: configuration space with validity checker and local planner.
        start: start configuration ``q_start`` (size d).
        goal: goal configuration ``q_goal`` (size d); or several (k, d), or a
            :class:`~taskspace.planning.GoalRegion` (e.g. :class:`taskspace.ik.PoseGoalRegion`,
            :class:`taskspace.ik.FeatureGoalRegion`), as OMPL's goal states and sampleable
            goal regions: every goal configuration (for a region: its valid samples, 20
            drawn first, one more every 64 iterations, up to 32; when none of the first 20
            is valid, one more per iteration until one is) is a root of the goal tree,
            and the path ends at whichever the trees connect to (``log["goal_states"]``). A
            start inside the region is a one-point path. Goal sets plan with the Python
            planner (the compiled one takes one goal).
        options: planner settings.
        rng: random generator (default: ``np.random.default_rng(options.seed)``); the
            compiled planner draws its seed from it.

    Returns:
        A :class:`PlannerResult`; ``trees`` holds the start and goal trees; ``log`` has the
        node counts, the candidate paths rejected by the fine check (``lazy_rejections``),
        the nodes removed with them and the turns taken by a trapped tree (``trapped_turns``);
        with ``certify``, ``certified``, ``min_distance`` [m] and ``certify_attempts``. The
        compiled planner adds its checker, validator and re-check counts and the wall time
        of its phases [us] (``kernel_run_us`` the whole call, ``kernel_endpoints_us``,
        ``kernel_line_us`` the straight start-goal line, ``kernel_nearest_us`` (an
        estimate: every 8th nearest-neighbour query timed, times 8),
        ``kernel_fine_pass_us``, ``kernel_recheck_us``; the tree growth is the rest).

    Set-up: with a sphere checker, the robot's sphere model and the compiled checker of the
    world are built (when they are not) before the plan's clock starts: the first plan for a
    robot whose spheres are not in the on-disk cache takes their fit (seconds) beyond its
    time limit, as OMPL's ``setup()`` precedes ``solve()``; ``time_s`` is the plan's.

    Interrupts and threads: the compiled planner runs with the GIL released and polls
    Python's signal handlers every 2 ms, so Ctrl-C stops it (``KeyboardInterrupt``) as it
    stops the Python path. Two threads may plan at the same time on spaces with *different*
    checkers (each compiled checker is locked by the plan that uses it: plans and queries on
    one shared checker run one after the other, with the same answers); the random streams
    are per call, so a seeded plan gives the same path in a thread as alone. A space, its
    checker and the robot's world must not be modified while a plan on them runs.

    Raises:
        PlanningError: start or goal outside the bounds or in collision (the message lists
            the colliding pairs).
        InvalidInputError: invalid options (a non-integer or negative ``max_iterations`` or
            ``seed``, a NaN or negative ``time_limit_s``, a step or resolution too small for
            the bounds).
        KeyboardInterrupt: Ctrl-C (SIGINT) during the plan.

    Certified paths: with ``options.certify`` the returned path is proven free between its
    checked points by :func:`~taskspace.planning.certify_path` (conservative advancement on
    the robot's geometry); an uncertified path is re-planned with the next seeds
    (``certify_retries`` times, within the time limit; the compiled planner certifies the
    motions near the spots of earlier failures in the kernel) and, if none can be certified,
    the result has ``success=False``, status ``UNCERTIFIED`` and the failing segments in
    ``log`` (``certify_failures``).
    """
    opts = options or _DEFAULT_OPTIONS
    kernel = None
    if opts.checker != "mesh" and opts.native:
        kernel = _sphere_setup(space)  # once per robot and world, before the clock: set-up
    t0 = time.perf_counter()  # time_s counts the whole call, the validation included
    if not opts.certify:
        return _plan(space, start, goal, opts, rng, t0, None, kernel)
    return plan_certified(
        space, opts, lambda o, r: _plan(space, start, goal, o, rng, time.perf_counter(), r)
    )


def _sphere_setup(space: ConfigurationSpace) -> Any:
    """Build the sphere checker of ``space`` if it is not built (:func:`rrt_connect`).

    The robot's sphere model (fitted in seconds for a robot the on-disk cache does not hold)
    and the compiled checker of a new world are set-up, as OMPL's ``setup()`` before
    ``solve()``: built before the plan's clock starts, so that a first plan is not spent on
    them (it ended with TIME_LIMIT after 0 iterations when the fit outlasted the limit).

    Returns:
        The sphere kernel (:meth:`~taskspace.planning.CollisionChecker.sphere_kernel`) of a
        :class:`~taskspace.planning.CollisionChecker` on a Euclidean space: what
        :func:`_native_kernel` gives for a sphere checker (unless ``partial_extend``);
        ``None`` for other spaces or without the compiled checker.
    """
    checker = space.checker
    if type(checker) is CollisionChecker and space.is_euclidean:
        return checker.sphere_kernel_ready()
    return None


class _Settings(NamedTuple):
    """The validated options of a plan (:func:`_validate`)."""

    alpha: float
    """``step_size`` [rad or m]."""
    max_iterations: int
    """The iteration cap (``2**63 - 1`` for none)."""
    time_limit: float
    """The time limit [s] (``math.inf`` for none)."""
    seed: int
    coarse: float | None
    """``coarse_resolution`` [rad or m] (``None``: the space's resolution)."""
    fallback: int
    """The kernel's ``fallback_iterations`` (-1: never)."""
    checker: int
    """Index of ``checker`` in :data:`CHECKERS`."""
    validator: int
    """Index of ``validator`` in :data:`VALIDATORS`."""


def _validate(opts: RRTConnectOptions) -> _Settings:
    """Check every option of :func:`rrt_connect` that does not depend on the space.

    Raises:
        InvalidInputError: an invalid value (the message names the option).
        UnknownNameError: an unknown ``checker`` or ``validator``.
    """
    settings = _usual_settings(opts)
    if settings is not None:
        return settings
    return _checked_settings(opts)


_CHECKER_CODES = {name: code for code, name in enumerate(CHECKERS)}
_VALIDATOR_CODES = {name: code for code, name in enumerate(VALIDATORS)}


def _usual_settings(opts: RRTConnectOptions) -> _Settings | None:
    """:func:`_checked_settings` of usual options, else ``None``.

    Usual: every field has its usual type (float, int, ``None``, str; each is read once) and
    a valid value. The same settings as :func:`_checked_settings` (which gives the errors and
    converts other types: numpy numbers, an int time limit) in fewer steps: a new options
    object per plan is common, and a compiled plan takes a fraction of a millisecond.
    """
    alpha = opts.step_size
    name: Any = opts.checker
    checker = _CHECKER_CODES.get(name) if type(name) is str else None
    name = opts.validator
    validator = _VALIDATOR_CODES.get(name) if type(name) is str else None
    cap = opts.max_iterations
    limit = opts.time_limit_s
    seed = opts.seed
    local = opts.local_sampling
    sigma = opts.local_sigma
    trapped = opts.trapped_priority
    fallback = opts.fallback_iterations
    coarse = opts.coarse_resolution
    if limit is None:
        limit = _INF
    elif type(limit) is not float or not limit >= 0.0:  # NaN too
        return None
    if cap is None:
        if limit == _INF:  # no limit at all: refused
            return None
        cap = _LONG_MAX
    elif type(cap) is not int or cap < 0:
        return None
    elif cap > _LONG_MAX:
        cap = _LONG_MAX
    if fallback is None:
        fallback = -1
    elif type(fallback) is not int or fallback < 0:
        return None
    elif fallback > _LONG_MAX:
        fallback = _LONG_MAX
    if (
        type(alpha) is not float
        or not 0.0 < alpha < _INF
        or checker is None
        or validator is None
        or type(seed) is not int
        or seed < 0
        or type(local) is not float
        or not 0.0 <= local <= 1.0
        or type(sigma) is not float
        or not 0.0 < sigma < _INF
        or type(trapped) is not float
        or not 0.0 <= trapped <= 1.0
        or not (coarse is None or (type(coarse) is float and 0.0 < coarse < _INF))
    ):
        return None
    # tuple.__new__: the NamedTuple without its Python-level __new__ (0.15 us less)
    return _NEW_TUPLE(_Settings, (alpha, cap, limit, seed, coarse, fallback, checker, validator))


_INF = math.inf
_NEW_TUPLE = tuple.__new__


def _checked_settings(opts: RRTConnectOptions) -> _Settings:
    """:func:`_validate`'s checks one by one, in order, with their messages."""
    alpha = check_positive(opts.step_size, "step_size")
    if opts.checker not in CHECKERS:
        raise UnknownNameError("checker", str(opts.checker), CHECKERS)
    if opts.validator not in VALIDATORS:
        raise UnknownNameError("validator", str(opts.validator), VALIDATORS)
    max_iterations, time_limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    seed = check_seed(opts.seed)
    if not 0.0 <= opts.local_sampling <= 1.0:
        raise InvalidInputError(f"local_sampling must be in [0, 1], got {opts.local_sampling}")
    check_positive(opts.local_sigma, "local_sigma")
    if not 0.0 <= opts.trapped_priority <= 1.0:
        raise InvalidInputError(f"trapped_priority must be in [0, 1], got {opts.trapped_priority}")
    fallback = -1
    if opts.fallback_iterations is not None:
        fallback = min(check_count(opts.fallback_iterations, "fallback_iterations"), _LONG_MAX)
    coarse = None
    if opts.coarse_resolution is not None:
        coarse = check_positive(opts.coarse_resolution, "coarse_resolution")
    return _Settings(
        alpha,
        max_iterations,
        time_limit,
        seed,
        coarse,
        fallback,
        CHECKERS.index(opts.checker),
        VALIDATORS.index(opts.validator),
    )


def _plan(
    space: ConfigurationSpace,
    start: Any,
    goal: Any,
    opts: RRTConnectOptions,
    rng: np.random.Generator | None,
    t0: float,
    regions: FailedRegions | None = None,
    sphere_kernel: Any = None,
) -> PlannerResult:
    """:func:`rrt_connect` without certification (``t0``: its ``time.perf_counter()`` [s]).

    ``regions``: the failed regions of earlier certificates (a certified re-plan): every edge
    of the trees and the straight start-goal line must be certified inside them
    (:class:`~taskspace.planning.certify.FailedRegions`); the compiled planner certifies in
    the kernel when it can, else this module's planner runs. ``sphere_kernel``: what
    :func:`_sphere_setup` returned before the clock started (``None``: none or not called).
    """
    settings = _validate(opts)  # at every call: the usual types are checked in a few steps
    alpha = settings.alpha
    delta = space.edge_resolution
    coarse = settings.coarse
    delta_c = coarse if coarse is not None and coarse > delta else delta  # max(delta, coarse)
    bounds = space.bounds_diameter()
    diameter = bounds[2]
    shortest = delta if delta < alpha else alpha  # min(alpha, delta) (builtins cost 0.1 us)
    if diameter / shortest > _MAX_LINE_PIECES or delta_c / delta > _MAX_LINE_PIECES:
        raise InvalidInputError(
            f"step_size={alpha:g} and the space's resolution {delta:g} are too small for bounds "
            f"of diameter {diameter:g}: a line would need more than 2^30 steps or checks; "
            "use larger values"
        )
    seed = settings.seed
    goal_set = is_goal_set(goal)  # several goals or a region: the Python planner
    if goal_set:
        kernel = None
    elif sphere_kernel is not None:  # _native_kernel's answer, taken before the clock
        kernel = None if opts.partial_extend else sphere_kernel
    else:
        kernel = _native_kernel(space, opts)
    in_kernel = None  # the failed regions as the kernel takes them
    if kernel is not None and regions is not None:
        in_kernel = regions.kernel_regions()
        if in_kernel is None:
            kernel = None
    if kernel is not None:  # the kernel checks the endpoints' bounds and collisions
        q_start = space.endpoint_vector(start, "start")
        q_goal = space.endpoint_vector(goal, "goal")
        seed = seed if rng is None else int(rng.integers(1 << 63))
        checker = settings.checker
        if checker and type(space.checker) is LockedJointChecker:
            checker = 0  # its kernel: exact checks ("mesh")
        result = _rrt_connect_native(
            space, kernel, checker, q_start, q_goal, opts, settings, bounds, delta, delta_c,
            seed, t0, 0, in_kernel, regions,
        )  # fmt: skip
        if not result.log["sphere_recheck_failed"]:
            return result
        # the exact checker refused the sphere checker's path: plan again with it
        logger.warning(
            "rrt_connect: path of the %s checker not exact-valid; mesh", CHECKERS[checker]
        )
        assert isinstance(space.checker, CollisionChecker)  # as _native_kernel requires
        kernel = space.checker.native_kernel()
        retry = _rrt_connect_native(
            space, kernel, 0, q_start, q_goal, opts, settings, bounds, delta, delta_c, seed, t0,
            result.collision_checks, in_kernel, regions,
        )  # fmt: skip
        retry.log["sphere_recheck_failed"] = 1.0
        return retry
    max_iterations, time_limit = settings.max_iterations, settings.time_limit
    checks0, edges0 = space.checks, space.edge_checks
    q_start = space.check_endpoint(start, "start")
    rng = rng if rng is not None else np.random.default_rng(seed)
    budget = Budget(max_iterations, time_limit, t0)
    deadline = budget.deadline
    region = None
    if goal_set:
        goals, region = goal_states(space, goal)
        if region is not None:
            goals = region_samples(space, region, rng, REGION_FIRST_ATTEMPTS, deadline)
    else:
        goals = [space.check_endpoint(goal, "goal")]
    searched = 0  # iterations spent drawing a first goal state when the first draws gave none
    if region is not None and not goals and not region.contains(q_start):
        # no tree can grow towards the region before one of its samples is valid: one more
        # draw per iteration, under the limits
        while not goals and not budget.exhausted(searched):
            searched += 1
            goals = region_samples(space, region, rng, 1, deadline)
    metric = None if space.is_euclidean else space.distances
    lines = _LinePlanner(alpha, delta, delta_c)
    status = PlannerStatus.ITERATION_LIMIT
    path: FloatArray = np.empty((0, space.dim))
    iterations = rejections = removed = turns = 0
    tree_start = _GrowingTree(q_start, metric)
    # every goal configuration is a root of the goal tree (OMPL's goal states)
    tree_goal = _GrowingTree(goals[0] if goals else q_start, metric)
    for q_goal in goals[1:]:
        tree_goal.add(q_goal, -1)
    order = np.argsort(space.distances(np.asarray(goals), q_start)).tolist() if goals else []
    direct = late = -1
    for g in order:  # the straight lines to the goals, nearest first
        free = budget.motion_valid(space, q_start, goals[g])
        if free is None:
            late = 1
            break
        if free and regions is not None:
            free = regions.allows(q_start, goals[g])
        if free:
            direct = g
            break
    if region is not None and region.contains(q_start):
        path = q_start[None, :].copy()
        status = PlannerStatus.SOLVED
    elif not goals:  # a region none of whose samples was valid within the limits
        status = PlannerStatus.TIME_LIMIT if budget.stopped_by == "time" else status
        iterations = searched
    elif direct >= 0:
        path = np.stack([q_start, goals[direct]])
        status = PlannerStatus.SOLVED
    elif late >= 0:
        status = PlannerStatus.TIME_LIMIT
    else:
        tree_a, tree_b = tree_start, tree_goal
        block = 256
        local = opts.local_sampling
        trapped = opts.trapped_priority
        samples = space.sample_uniform(rng, block)
        iterations = searched
        for iterations in range(searched + 1, max_iterations + 1):
            if budget.out_of_time():
                status = PlannerStatus.TIME_LIMIT
                break
            j = (iterations - searched - 1) % block
            if j == 0 and iterations > searched + 1:
                samples = space.sample_uniform(rng, block)
            q_rand = samples[j]
            if region is not None and iterations % _REGION_EVERY == 0 and len(goals) < 32:
                for q_goal in region_samples(space, region, rng, 1, deadline):
                    goals.append(q_goal)  # one more goal state: a new root of the goal tree
                    tree_goal.add(q_goal, -1)
            if trapped > 0.0 and 4 * len(tree_b.nn) < len(tree_a.nn) and rng.random() < trapped:
                # T_b is trapped: it takes T_a's turn (the trees are swapped back below).
                tree_a, tree_b = tree_b, tree_a
                turns += 1
            if local > 0.0 and 4 * len(tree_a.nn) < len(tree_b.nn) and rng.random() < local:
                # T_a is trapped (typically in a tight goal region): aim near one of its nodes.
                i_node = int(rng.integers(len(tree_a.nn)))
                if i_node in tree_a.removed:  # (its coordinates are zeros: no configuration)
                    live = [j for j in range(len(tree_a.nn)) if j not in tree_a.removed]
                    i_node = live[int(rng.integers(len(live)))]
                node = tree_a.nn.points[i_node]
                if space.is_euclidean:
                    q_rand = node + opts.local_sigma * rng.standard_normal(space.dim)
                    q_rand = np.clip(q_rand, space.lower, space.upper)
                else:  # towards a random sample, at most sigma away (on the manifold)
                    far = space.sample_uniform(rng)
                    gap_r = space.distance(node, far)
                    q_rand = space.interpolate(node, far, min(1.0, opts.local_sigma / gap_r))[0]
            a_new = _extend(space, tree_a, lines, q_rand, opts.partial_extend, budget, regions)
            if a_new == _LATE:
                status = PlannerStatus.TIME_LIMIT
                break
            if a_new >= 0:
                # CONNECT(T_b, q_new): the whole line of steps in one checker call.
                q_new = tree_a.nn.points[a_new]
                j_near, gap = tree_b.nn.nearest(q_new)
                if gap == 0.0:
                    b_new, reached, late_b = j_near, True, False
                else:
                    space.edge_checks += 1
                    b_new, reached, late_b = _grow(
                        space, tree_b, lines, j_near, q_new, gap, 1 << 30, True, budget, regions
                    )
                if late_b:
                    status = PlannerStatus.TIME_LIMIT
                    break
                if reached:
                    ok = True
                    if lines.lazy:
                        leaves = [(tree_a, a_new), (tree_b, b_new)]
                        if tree_a is tree_start:
                            leaves.reverse()  # goal tree first
                        ok, lost, late_v = _verify(space, leaves, lines.stride, budget)
                        if late_v:
                            status = PlannerStatus.TIME_LIMIT
                            break
                        rejections += not ok
                        removed += lost
                    if ok:
                        half_a = tree_a.nn.points[tree_a.path_indices(a_new)[::-1]]
                        half_b = tree_b.nn.points[tree_b.path_indices(b_new)[1:]]
                        path = np.vstack([half_a, half_b])
                        if tree_a is tree_goal:
                            path = path[::-1].copy()
                        status = PlannerStatus.SOLVED
                        break
            tree_a, tree_b = tree_b, tree_a
    dt = time.perf_counter() - t0
    success = status is PlannerStatus.SOLVED
    logger.debug(
        "rrt_connect %s in %.3f s, %d iterations, %d+%d nodes, %d lazy rejections",
        status.value,
        dt,
        iterations,
        len(tree_start.nn),
        len(tree_goal.nn),
        rejections,
    )
    return PlannerResult(
        success=success,
        status=status,
        path=path,
        path_length=result_length(space, path, success),
        iterations=iterations,
        collision_checks=space.checks - checks0,
        edge_checks=space.edge_checks - edges0,
        time_s=dt,
        trees=[tree_start.freeze(), tree_goal.freeze()],
        log={
            "start_tree_nodes": float(len(tree_start.nn)),
            "goal_tree_nodes": float(len(tree_goal.nn)),
            "lazy_rejections": float(rejections),
            "nodes_removed": float(removed),
            "trapped_turns": float(turns),
            "goal_states": float(len(goals)),
            **limit_log(status, result_length(space, path, success), dt),
        },
    )


_REGION_EVERY = 64
"""A goal region is sampled again every this many iterations (up to 32 goal states)."""

_LATE = -2
""":func:`_extend`'s answer when the deadline passed before its check."""
