"""Bug1 and Bug2 (slides 3:8-3:12): minimal sensor-based planners for a point in the plane.

Both alternate *motion-to-goal* (drive straight at the goal) and *boundary following*
(walk around the obstacle that was hit, keeping it on one side).

* **Bug1**: walk once completely around the obstacle from the hit point ``H``, remember the
  boundary point ``L`` closest to the goal, walk back to ``L`` the shorter way and leave
  there. If driving from ``L`` towards the goal enters the obstacle, the goal is unreachable.
* **Bug2** (slide 3:11): the *m-line* is the segment start-goal. Follow the boundary until
  the m-line is met again at a point closer to the goal than ``H`` from which the goal
  direction is free, then leave. Returning to ``H`` means the goal is unreachable.

Both terminate in a world of finitely many disjoint polygons. Bug1 travels at most
``|start goal| + 1.5 sum_i perimeter_i``.

Thread safety: :class:`BugOptions` and :class:`BugStatus` are immutable; the planners keep their
state local to the call (the world is only read); a :class:`BugResult` is plain result data, not
locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
import itertools
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from taskspace._validation import check_count, check_positive
from taskspace.errors import PlanningError, UnknownNameError
from taskspace.planning.polygon_world import PolygonWorld, SegmentHit

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


class BugStatus(enum.Enum):
    """Outcome of a Bug run."""

    REACHED = "reached"
    GOAL_UNREACHABLE = "goal_unreachable"
    ITERATION_LIMIT = "iteration_limit"


@dataclass(frozen=True, kw_only=True)
class BugOptions:
    """Settings of :func:`bug1` / :func:`bug2`.

    Attributes:
        turn: ``"left"`` turns left at an obstacle (obstacle kept on the robot's right),
            ``"right"`` the opposite.
        max_hits: give up after this many obstacle encounters.
        tolerance: geometric tolerance [m] (points closer than this are equal).
    """

    turn: Literal["left", "right"] = "left"
    max_hits: int = 200
    tolerance: float = 1e-9


@dataclass
class BugResult:
    """Result of a Bug run.

    Attributes:
        success: whether the goal was reached.
        status: why the run stopped.
        path: waypoints ``(N, 2)`` of the travelled polyline [m], start first.
        length: travelled distance [m].
        hit_points: where motion-to-goal met an obstacle [m].
        leave_points: where boundary following was left [m].
        time_s: wall-clock time [s].
    """

    success: bool
    status: BugStatus
    path: FloatArray
    length: float
    hit_points: list[FloatArray] = field(default_factory=list)
    leave_points: list[FloatArray] = field(default_factory=list)
    time_s: float = 0.0


def _boundary_walk(world: PolygonWorld, hit: SegmentHit, forward: bool) -> list[FloatArray]:
    """Vertices of one full loop walk from the hit point back to it."""
    loop = int(world.edge_loop[hit.edge])
    v = world.loop_vertices[loop]
    n = len(v)
    k = hit.edge - int(world.loop_first_edge[loop])
    if forward:  # along stored direction (obstacle on the left)
        order = [v[(k + 1 + i) % n] for i in range(n)]
    else:
        order = [v[(k - i) % n] for i in range(n)]
    return [hit.point, *order, hit.point]


def _first_hit(world: PolygonWorld, p: FloatArray, g: FloatArray, tol: float) -> SegmentHit | None:
    """First boundary hit on ``p -> g`` that enters an obstacle (grazing contacts skipped)."""
    seg = g - p
    L = float(np.linalg.norm(seg))
    if L <= tol:
        return None
    direction = seg / L
    for h in world.segment_hits(p, g):
        if h.t * L <= tol:
            # we start on this edge: does the goal direction enter the obstacle?
            if world.contains(p + 1e-7 * max(L, 1.0) * direction)[0]:
                return SegmentHit(0.0, p.copy(), h.edge, h.polygon)
            continue
        a, b = world.edges[h.edge]
        e = b - a
        # entering the interior: interior is on the left of a -> b
        if e[0] * direction[1] - e[1] * direction[0] > 0:
            return h
        probe = h.point + 1e-7 * max(L, 1.0) * direction
        if world.contains(probe)[0]:
            return h
    return None


def _polyline_length(points: list[FloatArray]) -> float:
    return float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(points)))


def _closest_on_segment(a: FloatArray, b: FloatArray, g: FloatArray) -> tuple[FloatArray, float]:
    d = b - a
    dd = float(d @ d)
    s = 0.0 if dd == 0 else float(np.clip((g - a) @ d / dd, 0.0, 1.0))
    return a + s * d, s


def _segment_cross(
    p: FloatArray, q: FloatArray, a: FloatArray, b: FloatArray
) -> tuple[float, float] | None:
    r = q - p
    e = b - a
    den = r[0] * e[1] - r[1] * e[0]
    if abs(den) < 1e-15:
        return None
    ap = a - p
    t = (ap[0] * e[1] - ap[1] * e[0]) / den
    s = (ap[0] * r[1] - ap[1] * r[0]) / den
    if -1e-12 <= t <= 1 + 1e-12 and -1e-12 <= s <= 1 + 1e-12:
        return float(t), float(s)
    return None


def _run(
    world: PolygonWorld,
    start: Any,
    goal: Any,
    options: BugOptions,
    variant: Literal["bug1", "bug2"],
) -> BugResult:
    t0 = time.perf_counter()
    if options.turn not in ("left", "right"):
        raise UnknownNameError("turn", str(options.turn), ["left", "right"])
    max_hits = check_count(options.max_hits, "max_hits", minimum=1)
    s = world.check_free_point(start, "start")
    g = world.check_free_point(goal, "goal")
    tol = check_positive(options.tolerance, "tolerance", strict=False)
    forward = options.turn == "right"  # stored edges keep the obstacle on the left
    path: list[FloatArray] = [s.copy()]
    hits: list[FloatArray] = []
    leaves: list[FloatArray] = []
    x = s.copy()

    def done(status: BugStatus) -> BugResult:
        pts = [path[0]]
        for p in path[1:]:
            if np.linalg.norm(p - pts[-1]) > tol:
                pts.append(p)
        return BugResult(
            success=status is BugStatus.REACHED,
            status=status,
            path=np.asarray(pts),
            length=_polyline_length(pts),
            hit_points=hits,
            leave_points=leaves,
            time_s=time.perf_counter() - t0,
        )

    for _ in range(max_hits):
        hit = _first_hit(world, x, g, tol)
        if hit is None:
            path.append(g.copy())
            return done(BugStatus.REACHED)
        path.append(hit.point.copy())
        hits.append(hit.point.copy())
        walk = _boundary_walk(world, hit, forward)
        d_hit = float(np.linalg.norm(hit.point - g))
        if variant == "bug2":
            left_at: FloatArray | None = None
            for i, (a, b) in enumerate(itertools.pairwise(walk)):
                cp, _ = _closest_on_segment(a, b, g)
                if np.linalg.norm(cp - g) <= tol:  # goal on the boundary
                    path.extend([*walk[1 : i + 1], g.copy()])
                    return done(BugStatus.REACHED)
                c = _segment_cross(s, g, a, b)
                if c is None:
                    continue
                xpt = a + c[1] * (b - a)
                if np.linalg.norm(xpt - g) >= d_hit - 1e-9 * max(1.0, d_hit):
                    continue
                h_leave = _first_hit(world, xpt, g, tol)
                if h_leave is not None and np.allclose(h_leave.point, xpt, atol=1e-9):
                    continue  # goal direction enters the obstacle here
                path.extend([*walk[1 : i + 1], xpt])
                left_at = xpt
                break
            if left_at is None:
                path.extend(walk[1:])
                return done(BugStatus.GOAL_UNREACHABLE)
            leaves.append(left_at.copy())
            x = left_at
        else:
            best_d, best_i, best_p = math.inf, 0, walk[0]
            for i, (a, b) in enumerate(itertools.pairwise(walk)):
                cp, _ = _closest_on_segment(a, b, g)
                dcp = float(np.linalg.norm(cp - g))
                if dcp < best_d - 1e-12:
                    best_d, best_i, best_p = dcp, i, cp
            # full circumnavigation, then back to L along the shorter way
            path.extend(walk[1:])
            to_l = [*walk[1 : best_i + 1], best_p]
            back = [*walk[::-1][1 : len(walk) - 1 - best_i], best_p]
            path.extend(
                to_l
                if _polyline_length([walk[0], *to_l]) <= _polyline_length([walk[0], *back])
                else back
            )
            if best_d <= tol:
                path.append(g.copy())
                return done(BugStatus.REACHED)
            leaves.append(best_p.copy())
            h2 = _first_hit(world, best_p, g, tol)
            if h2 is not None and np.linalg.norm(h2.point - best_p) <= 1e-9:
                return done(BugStatus.GOAL_UNREACHABLE)
            x = best_p
    logger.info("%s stopped after %d obstacle hits", variant, max_hits)
    return done(BugStatus.ITERATION_LIMIT)


def bug1(
    world: PolygonWorld, start: Any, goal: Any, *, options: BugOptions | None = None
) -> BugResult:
    """Bug1: circumnavigate each obstacle hit and leave at its point closest to the goal.

    Args:
        world: polygonal obstacles.
        start: start point ``(x, y)`` [m].
        goal: goal point ``(x, y)`` [m].
        options: settings.

    Returns:
        A :class:`BugResult`; ``status`` is ``GOAL_UNREACHABLE`` when the goal is enclosed.

    Raises:
        PlanningError: if start or goal is out of bounds or inside an obstacle.
    """
    return _run(world, start, goal, options or BugOptions(), "bug1")


def bug2(
    world: PolygonWorld, start: Any, goal: Any, *, options: BugOptions | None = None
) -> BugResult:
    """Bug2 (slide 3:11): follow the boundary until the m-line is met closer to the goal.

    Args:
        world: polygonal obstacles.
        start: start point ``(x, y)`` [m].
        goal: goal point ``(x, y)`` [m].
        options: settings.

    Returns:
        A :class:`BugResult`; ``status`` is ``GOAL_UNREACHABLE`` when the walk returns to
        the hit point without a valid leave point (goal enclosed).

    Raises:
        PlanningError: if start or goal is out of bounds or inside an obstacle.
    """
    return _run(world, start, goal, options or BugOptions(), "bug2")


__all__ = ["BugOptions", "BugResult", "BugStatus", "PlanningError", "bug1", "bug2"]
