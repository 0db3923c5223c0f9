"""RRT with differential constraints for the car (slides 3:57-3:60).

Slide 3:57::

    V = {q_start}
    for i = 0..k:
        q_target <- random sample from Q            (the goal with probability beta)
        q_near   <- nearest neighbour of q_target in V
        u        <- local planner steering q_near towards q_target
        q_new    <- q_near + int_0^tau qdot(q, u) dt
        if the motion is in Q_free: V <- V + {q_new}, E <- E + {(q_near, q_new)}

The two crucial questions of the slide are answered with the curves of slide 3:60: the
**metric** is the Reeds-Shepp (with reverse) or Dubins (forward only) length, and the
**steering function** drives the first ``step_length`` metres of that optimal curve (exact
arcs, so the tree respects ``|phi| <= Phi``). When a new node is within ``connect_distance``
of the goal (in that metric), the exact curve to the goal is tried, which hits the goal pose
exactly. The ``"controls"`` steering is the control-based sampling of slide 3:51 (best of a few
random constant controls, goal reached within tolerances).

Nearest neighbours: the curve length is at least the Euclidean distance between positions,
so the ``nearest_candidates`` nodes closest in the naive SE(2) metric of slide 3:58 are
re-ranked by the exact curve length (vectorised).

Thread safety: :class:`KinodynamicRRTOptions` and :class:`RRTStatus` are immutable;
:func:`kinodynamic_rrt` keeps its state local to the call (the world is only read); a
:class:`KinodynamicRRTResult` is plain result data, not locked: do not modify it while another
thread reads it.
"""

from __future__ import annotations

import enum
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from taskspace._validation import (
    as_vector,
    check_count,
    check_positive,
    check_seed,
)
from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.car import CarModel, sample_motion
from taskspace.planning.dubins import dubins_distance, dubins_shortest
from taskspace.planning.limits import planner_limits
from taskspace.planning.polygon_world import PolygonWorld
from taskspace.planning.reeds_shepp import reeds_shepp_distance, reeds_shepp_shortest
from taskspace.planning.se2 import CurvePath, angle_distance, se2_distance

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

_STEERINGS = ("reeds_shepp", "dubins", "controls")


@dataclass(frozen=True, kw_only=True)
class KinodynamicRRTOptions:
    """Settings of :func:`kinodynamic_rrt`.

    Attributes:
        steering: ``"reeds_shepp"`` (forward and reverse), ``"dubins"`` (forward only) or
            ``"controls"`` (random constant controls, slide 3:51).
        max_iterations: number of sampling iterations ``k`` (an integer >= 0, or ``None``
            with a finite time limit: :mod:`taskspace.planning.limits`).
        goal_bias: probability ``beta`` of sampling the goal.
        step_length: arc length driven per extension, ``|v| tau`` [m].
        connect_distance: try the exact curve to the goal from new nodes closer than this
            (curve metric) [m].
        goal_position_tolerance: ``"controls"`` steering: goal position tolerance [m].
        goal_angle_tolerance: ``"controls"`` steering: goal heading tolerance [rad].
        collision_step: spacing of footprint checks along motions [m].
        nearest_candidates: nodes pre-selected by the SE(2) metric before exact ranking.
        rotation_weight: length scale [m] of the heading in the SE(2) metric.
        n_control_samples: random controls tried per extension (``"controls"``).
        time_limit_s: wall-clock budget [s] (``None`` or ``math.inf`` = no limit; NaN is
            refused); the clock is read before every motion's check (the extension, the
            curve to the goal), so the overrun is one motion's check at most.
        seed: random seed (an integer >= 0) used when no ``rng`` is passed.
        certify: must stay ``False``: ``True`` is refused (``InvalidInputError``). The
            other planners' certification (:func:`~taskspace.planning.certify_path`) proves
            straight joint-space segments free on a Pinocchio/coal robot by conservative
            advancement; a car path is a chain of arcs (exact Reeds-Shepp/Dubins curves, or
            constant-control arcs), not straight segments between its samples, and its
            footprint and obstacles are 2-D polygons of a
            :class:`~taskspace.planning.PolygonWorld`, which has no distance query to
            advance on. The footprint is checked every ``collision_step`` along the arcs;
            make that step finer than the thinnest obstacle for a denser check.
    """

    steering: Literal["reeds_shepp", "dubins", "controls"] = "reeds_shepp"
    max_iterations: int | None = 5000
    goal_bias: float = 0.1
    step_length: float = 2.0
    connect_distance: float = 8.0
    goal_position_tolerance: float = 0.3
    goal_angle_tolerance: float = 0.2
    collision_step: float = 0.1
    nearest_candidates: int = 24
    rotation_weight: float = 2.0
    n_control_samples: int = 10
    time_limit_s: float | None = None
    seed: int = 0
    certify: bool = False


class RRTStatus(enum.Enum):
    """Outcome of the kinodynamic RRT."""

    REACHED = "reached"
    ITERATION_LIMIT = "iteration_limit"
    TIME_LIMIT = "time_limit"


@dataclass
class KinodynamicRRTResult:
    """Result of :func:`kinodynamic_rrt`.

    Attributes:
        success: whether the goal was connected.
        status: why the search stopped.
        path: poses ``(N, 3)`` sampled every ``collision_step`` along the solution
            (``(0, 3)`` on failure).
        segments: the curve pieces of the solution, start to goal.
        controls: ``(v [m/s], phi [rad], tau [s])`` rows driving the solution at max speed.
        length: solution length [m] (``inf`` on failure).
        tree_nodes: tree poses ``(n, 3)``.
        tree_parents: parent of each node (``-1`` for the root).
        tree_edges: curve from the parent to each node (``None`` for the root).
        iterations: sampling iterations performed.
        n_nodes: tree size.
        n_collision_checks: footprint poses checked.
        n_rejected: extensions rejected for collision.
        time_s: total wall-clock time [s].
        time_nearest_s: time in nearest-neighbour queries [s].
        time_steer_s: time in steering (curve computation) [s].
        time_collision_s: time in collision checks [s].
    """

    success: bool
    status: RRTStatus
    path: FloatArray
    segments: list[CurvePath]
    controls: FloatArray
    length: float
    tree_nodes: FloatArray = field(repr=False)
    tree_parents: npt.NDArray[np.int64] = field(repr=False)
    tree_edges: list[CurvePath | None] = field(repr=False)
    iterations: int = 0
    n_nodes: int = 0
    n_collision_checks: int = 0
    n_rejected: int = 0
    time_s: float = 0.0
    time_nearest_s: float = 0.0
    time_steer_s: float = 0.0
    time_collision_s: float = 0.0


def _validate(opts: KinodynamicRRTOptions) -> None:
    if opts.certify is not False:
        raise InvalidInputError(
            "kinodynamic_rrt cannot certify its paths (certify=True): certify_path proves "
            "straight joint-space segments free on a Pinocchio/coal robot, while a car path "
            "is a chain of arcs whose footprint is checked against a PolygonWorld (no "
            "distance query to advance on); use certify=False and a collision_step finer "
            f"than the thinnest obstacle (now {opts.collision_step!r} m)"
        )
    if opts.steering not in _STEERINGS:
        raise UnknownNameError("steering", str(opts.steering), _STEERINGS)
    if not 0.0 <= opts.goal_bias <= 1.0:
        raise InvalidInputError(f"goal_bias must be in [0, 1], got {opts.goal_bias}")
    for name in ("nearest_candidates", "n_control_samples"):
        check_count(getattr(opts, name), name, minimum=1)
    planner_limits(opts.max_iterations, opts.time_limit_s)
    check_seed(opts.seed)
    for name in ("step_length", "connect_distance", "collision_step", "rotation_weight"):
        check_positive(getattr(opts, name), name)


def kinodynamic_rrt(
    model: CarModel,
    world: PolygonWorld,
    start: Any,
    goal: Any,
    *,
    options: KinodynamicRRTOptions | None = None,
    rng: np.random.Generator | None = None,
) -> KinodynamicRRTResult:
    """Plan a collision-free car path from ``start`` to ``goal`` (slide 3:57).

    Threads: Python code (the GIL runs one thread at a time; Ctrl-C interrupts it). Plans in
    several threads give the results of sequential runs when each thread has its own ``rng``
    (the car model and the world are only read).

    Args:
        model: the car (wheelbase, steering limit, footprint).
        world: obstacles; must have ``bounds`` (the sampling region).
        start: start pose ``(x, y, theta)`` [m, m, rad].
        goal: goal pose ``(x, y, theta)`` [m, m, rad].
        options: settings.
        rng: random generator (default ``np.random.default_rng(options.seed)``).

    Returns:
        A :class:`KinodynamicRRTResult`.

    Raises:
        PlanningError: if the world has no bounds, or start/goal is out of bounds or in
            collision.
        InvalidInputError: bad options; ``certify=True`` (see
            :class:`KinodynamicRRTOptions`: a car path of arcs in a polygon world cannot be
            certified).
    """
    t_start = time.perf_counter()
    opts = options or KinodynamicRRTOptions()
    _validate(opts)
    if world.bounds is None:
        raise PlanningError("kinodynamic_rrt needs world.bounds to sample configurations")
    q_start = as_vector(start, 3, "start")
    q_goal = as_vector(goal, 3, "goal")
    for name, q in (("start", q_start), ("goal", q_goal)):
        if not world.in_bounds(q[:2])[0]:
            raise PlanningError(
                f"{name} pose ({q[0]:g}, {q[1]:g}, {q[2]:g}) is outside the world bounds "
                f"{world.bounds}"
            )
        if not model.poses_free(world, q)[0]:
            raise PlanningError(
                f"{name} pose ({q[0]:g}, {q[1]:g}, {q[2]:g}) is in collision (car footprint "
                "overlaps an obstacle or the bounds)"
            )
    rng = rng if rng is not None else np.random.default_rng(opts.seed)
    r = model.turning_radius
    x0, y0, x1, y1 = world.bounds
    cap = 1024
    nodes = np.empty((cap, 3))
    nodes[0] = q_start
    parents = [-1]
    edges: list[CurvePath | None] = [None]
    n = 1
    t_nn = t_steer = t_col = 0.0
    n_checks = n_rejected = 0
    goal_node = -1
    status = RRTStatus.ITERATION_LIMIT
    steering = opts.steering

    def metric(a: FloatArray, b: FloatArray) -> FloatArray:
        if steering == "reeds_shepp":
            return reeds_shepp_distance(a, b, r)
        if steering == "dubins":
            return dubins_distance(a, b, r)
        return np.asarray(se2_distance(a, b, rotation_weight=opts.rotation_weight))

    def curve(a: FloatArray, b: FloatArray) -> CurvePath:
        if steering == "dubins":
            return dubins_shortest(a, b, r)
        return reeds_shepp_shortest(a, b, r)

    def free(poses: FloatArray) -> bool:
        nonlocal t_col, n_checks
        tc = time.perf_counter()
        ok = bool(np.all(model.poses_free(world, poses)))
        n_checks += len(poses)
        t_col += time.perf_counter() - tc
        return ok

    def add(q: FloatArray, parent: int, edge: CurvePath) -> int:
        nonlocal nodes, n
        if n == nodes.shape[0]:
            nodes = np.concatenate([nodes, np.empty_like(nodes)])
        nodes[n] = q
        parents.append(parent)
        edges.append(edge)
        n += 1
        return n - 1

    def at_goal(q: FloatArray) -> bool:  # ("controls": within the goal tolerances)
        return bool(
            np.linalg.norm(q[:2] - q_goal[:2]) <= opts.goal_position_tolerance
            and angle_distance(q[2], q_goal[2]) <= opts.goal_angle_tolerance
        )

    def connect(i: int) -> bool:
        """The exact curve from node ``i`` to the goal, added if free."""
        nonlocal goal_node, t_steer
        ts = time.perf_counter()
        to_goal = curve(nodes[i], q_goal)
        poses = to_goal.sample(opts.collision_step)
        t_steer += time.perf_counter() - ts
        if free(poses):
            goal_node = add(q_goal.copy(), i, to_goal)
            return True
        return False

    it = 0
    cap, time_limit = planner_limits(opts.max_iterations, opts.time_limit_s)
    # the start itself may reach the goal (start == goal: the empty motion, whatever the
    # limits, as the other planners; the loop below tries the goal only from new nodes, which
    # gave a detour out and back); else under the clock, as the loop's own attempts
    in_time = np.array_equal(q_start, q_goal) or time.perf_counter() - t_start <= time_limit
    if steering == "controls":
        if at_goal(q_start):
            goal_node, status, cap = 0, RRTStatus.REACHED, 0
    elif in_time and float(metric(q_start, q_goal)[0]) <= opts.connect_distance and connect(0):
        status, cap = RRTStatus.REACHED, 0
    for it in range(1, cap + 1):
        if time.perf_counter() - t_start > time_limit:
            status = RRTStatus.TIME_LIMIT
            it -= 1
            break
        if rng.random() < opts.goal_bias:
            target = q_goal
        else:
            target = np.array(
                [rng.uniform(x0, x1), rng.uniform(y0, y1), rng.uniform(-math.pi, math.pi)]
            )
        tn = time.perf_counter()
        pre = se2_distance(nodes[:n], target, rotation_weight=opts.rotation_weight)
        k = min(opts.nearest_candidates, n)
        cand = np.argpartition(pre, k - 1)[:k] if k < n else np.arange(n)
        near = int(cand[np.argmin(metric(nodes[cand], target))])
        t_nn += time.perf_counter() - tn
        q_near = nodes[near]
        ts = time.perf_counter()
        if steering == "controls":
            speed = model.max_speed
            tau = opts.step_length / speed
            vs = rng.choice([-speed, speed], opts.n_control_samples)
            phis = rng.uniform(-model.max_steering, model.max_steering, opts.n_control_samples)
            u_all = np.stack([vs, phis], axis=1)
            ends = model.integrate(np.broadcast_to(q_near, (len(u_all), 3)), u_all, tau)
            best = int(np.argmin(se2_distance(ends, target, rotation_weight=opts.rotation_weight)))
            u = u_all[best]
            poses = sample_motion(model, q_near, u, tau, opts.collision_step)
            kappa = math.tan(float(u[1])) / model.wheelbase
            letter = "S" if abs(kappa) < 1e-12 else ("L" if kappa > 0 else "R")
            seg_r = r if letter == "S" else 1.0 / abs(kappa)
            piece = CurvePath(
                (float(q_near[0]), float(q_near[1]), float(q_near[2])),
                (letter,),
                (math.copysign(opts.step_length, float(u[0])),),
                seg_r,
                "control",
            )
        else:
            piece = curve(q_near, target).truncated(opts.step_length)
            poses = piece.sample(opts.collision_step)
        t_steer += time.perf_counter() - ts
        if piece.length < 1e-9 or not free(poses):
            n_rejected += 1
            continue
        new = add(poses[-1].copy(), near, piece)
        # try to finish
        q_new = nodes[new]
        if steering == "controls":
            if at_goal(q_new):
                goal_node = new
                status = RRTStatus.REACHED
                break
            continue
        if float(metric(q_new, q_goal)[0]) <= opts.connect_distance:
            if time.perf_counter() - t_start > time_limit:  # before the goal curve's check
                status = RRTStatus.TIME_LIMIT  # (the new node stays: its edge was checked)
                break
            if connect(new):
                status = RRTStatus.REACHED
                break
    segments: list[CurvePath] = []
    if goal_node >= 0:
        i = goal_node
        while parents[i] >= 0:
            e = edges[i]
            if e is not None:
                segments.append(e)
            i = parents[i]
        segments.reverse()
        if segments:
            path = np.concatenate(
                [s.sample(opts.collision_step)[(1 if j else 0) :] for j, s in enumerate(segments)]
            )
            controls = np.concatenate(
                [s.controls(model.wheelbase, model.max_speed) for s in segments]
            )
        else:  # the start is the goal ("controls" within its tolerances)
            path, controls = q_start[None, :].copy(), np.zeros((0, 3))
        length = float(sum(s.length for s in segments))
    else:
        path = np.zeros((0, 3))
        controls = np.zeros((0, 3))
        length = math.inf
    total = time.perf_counter() - t_start
    logger.info("kinodynamic RRT %s: %d nodes, %d iterations", status.value, n, it)
    return KinodynamicRRTResult(
        success=status is RRTStatus.REACHED,
        status=status,
        path=path,
        segments=segments,
        controls=controls,
        length=length,
        tree_nodes=nodes[:n].copy(),
        tree_parents=np.asarray(parents, dtype=np.int64),
        tree_edges=edges,
        iterations=it,
        n_nodes=n,
        n_collision_checks=n_checks,
        n_rejected=n_rejected,
        time_s=total,
        time_nearest_s=t_nn,
        time_steer_s=t_steer,
        time_collision_s=t_col,
    )


def parking_lot(
    lane_width: float = 8.4, slot_width: float = 3.4
) -> tuple[PolygonWorld, FloatArray, FloatArray]:
    """A parking-lot scene: a row of parked cars with one free perpendicular slot.

    Parked cars (2 m x 4.6 m, pitch 3.4 m) stand along the bottom edge ``y in [0.2, 4.8]``;
    the free slot is centred at ``x = 12``; a wall closes the lane at
    ``y = 4.8 + lane_width``. The car starts in the lane above the slot facing away
    (``theta = pi``), so a forward-only car must turn around in the lane.

    Args:
        lane_width: free width of the lane [m].
        slot_width: free width of the slot [m].

    Returns:
        ``(world, start, goal)`` with start ``(12, 4.8 + lane_width / 2, pi)`` and the goal
        nose-in in the slot ``(12, 3.3, -pi/2)``.
    """
    from taskspace.planning.polygon_world import Polygon

    check_positive(lane_width, "lane_width")
    check_positive(slot_width, "slot_width")
    half = 0.5 * slot_width
    top = 4.8 + lane_width
    cars = []
    for k in range(1, 4):
        for sgn in (-1.0, 1.0):
            cx = 12.0 + sgn * (half + 1.0 + (k - 1) * 3.4)
            cars.append(Polygon.rectangle(cx - 1.0, 0.2, cx + 1.0, 4.8))
    cars.append(Polygon.rectangle(0.0, top, 24.0, top + 0.8))  # wall along the lane
    world = PolygonWorld(tuple(cars), (0.0, 0.0, 24.0, top + 0.8))
    start = np.array([12.0, 4.8 + 0.5 * lane_width, math.pi])
    return world, start, np.array([12.0, 3.3, -0.5 * math.pi])
