"""Attractive / repulsive potential fields with gradient descent (slides 3:13-3:17).

Total potential (slide 3:15) ``U(q) = U_att(q) + U_rep(q)`` and force ``F = -grad U``.

Attractive (quadratic near the goal, conic far away, so the force stays bounded)::

    U_att = 1/2 zeta |q - q_g|^2                        if |q - q_g| <= d*
          = d* zeta |q - q_g| - 1/2 zeta d*^2            otherwise
    grad U_att = zeta (q - q_g)  or  d* zeta (q - q_g) / |q - q_g|

Repulsive (slide 3:14), summed over obstacles ``i`` with ``D_i(q)`` the distance to obstacle
``i`` and ``c_i`` its closest point::

    U_rep,i = 1/2 eta (1/D_i - 1/Q*)^2                  if D_i <= Q*, else 0
    grad U_rep,i = eta (1/Q* - 1/D_i) (1/D_i^2) (q - c_i) / D_i

Gradient descent ``q_{k+1} = q_k - alpha grad U(q_k)`` (step clipped to ``max_step``) is a
feedback controller: it can stop in a local minimum of ``U`` that is not the goal (slide 3:16),
for instance inside a concave obstacle facing the goal.

Thread safety: :class:`PotentialField`, :class:`PotentialFieldOptions` and :class:`PotentialStatus`
are immutable; the descent keeps its state local to the call; a :class:`PotentialFieldResult` is
plain result data, not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
import logging
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import (
    as_float_array,
    as_vector,
    check_count,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError
from taskspace.planning.polygon_world import PolygonWorld

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class PotentialFieldOptions:
    """Parameters of the potential and of gradient descent.

    Attributes:
        zeta: attractive gain ``zeta`` [1/s^2 style units; potential per m^2].
        d_star: radius ``d*`` where the attractive potential turns conic [m].
        eta: repulsive gain ``eta`` [potential * m^2].
        q_star: influence distance ``Q*`` of obstacles [m].
        step_size: gradient step ``alpha`` [m per unit gradient].
        max_step: largest displacement per iteration [m].
        goal_tolerance: success when ``|q - q_g|`` is below this [m].
        gradient_tolerance: local minimum when ``|grad U|`` is below this.
        stall_window: iterations over which a net displacement below ``stall_distance``
            declares a local minimum (catches oscillation around a minimum).
        stall_distance: see ``stall_window`` [m].
        max_iterations: iteration limit (an integer >= 0).
    """

    zeta: float = 1.0
    d_star: float = 2.0
    eta: float = 1.0
    q_star: float = 1.0
    step_size: float = 0.05
    max_step: float = 0.1
    goal_tolerance: float = 1e-2
    gradient_tolerance: float = 1e-4
    stall_window: int = 50
    stall_distance: float = 1e-3
    max_iterations: int = 5000


class PotentialStatus(enum.Enum):
    """Outcome of gradient descent."""

    REACHED = "reached"
    LOCAL_MINIMUM = "local_minimum"
    ITERATION_LIMIT = "iteration_limit"
    COLLISION = "collision"


@dataclass
class PotentialFieldResult:
    """Result of :func:`gradient_descent`.

    Attributes:
        success: whether the goal was reached.
        status: why descent stopped.
        path: visited points ``(N, 2)`` [m].
        potential: ``U`` along the path ``(N,)``.
        gradient_norm: ``|grad U|`` at the final point.
        iterations: number of descent steps.
        time_s: wall-clock time [s].
    """

    success: bool
    status: PotentialStatus
    path: FloatArray
    potential: FloatArray
    gradient_norm: float
    iterations: int
    time_s: float


def _points(points: Any) -> FloatArray:
    """``(2,)`` or ``(N, 2)`` finite points as ``(N, 2)``."""
    p = np.atleast_2d(as_float_array(points, "points"))
    if p.ndim != 2 or p.shape[1] != 2:
        raise InvalidInputError(f"points must have shape (2,) or (N, 2), got {np.shape(points)}")
    check_finite(p, "points")
    return p


@dataclass(frozen=True)
class PotentialField:
    """The potential ``U = U_att + U_rep`` of a goal in a polygon world (slide 3:15).

    Attributes:
        world: obstacles.
        goal: goal point [m].
        options: gains and radii.
    """

    world: PolygonWorld
    goal: FloatArray
    options: PotentialFieldOptions = PotentialFieldOptions()

    def __post_init__(self) -> None:
        object.__setattr__(self, "goal", as_vector(self.goal, 2, "goal"))
        o = self.options
        for name in ("zeta", "d_star", "eta", "q_star", "step_size", "max_step"):
            check_positive(getattr(o, name), name)
        for name in ("goal_tolerance", "gradient_tolerance", "stall_distance"):
            check_positive(getattr(o, name), name, strict=False)

    def attractive(self, points: Any) -> tuple[FloatArray, FloatArray]:
        """``U_att`` ``(N,)`` and its gradient ``(N, 2)`` at ``points`` ``(N, 2)``."""
        p = _points(points)
        o = self.options
        diff = p - self.goal
        r = np.linalg.norm(diff, axis=1)
        near = r <= o.d_star
        u = np.where(near, 0.5 * o.zeta * r**2, o.d_star * o.zeta * r - 0.5 * o.zeta * o.d_star**2)
        scale = np.where(near, o.zeta, o.d_star * o.zeta / np.maximum(r, 1e-300))
        return u, scale[:, None] * diff

    def repulsive(self, points: Any) -> tuple[FloatArray, FloatArray]:
        """``U_rep`` ``(N,)`` and its gradient ``(N, 2)``; ``inf`` inside obstacles."""
        p = _points(points)
        o = self.options
        dist, closest = self.world.closest_points(p)
        inside = self.world.contains(p)
        d = np.maximum(dist, 1e-12)
        active = d <= o.q_star
        inv = np.where(active, 1.0 / d - 1.0 / o.q_star, 0.0)
        u = 0.5 * o.eta * np.sum(inv**2, axis=1)
        coef = np.where(active, -o.eta * inv / d**3, 0.0)  # eta (1/Q* - 1/D) / D^2 / D
        grad = np.sum(coef[..., None] * (p[:, None, :] - closest), axis=1)
        u = np.where(inside, np.inf, u)
        return u, grad

    def value(self, points: Any) -> FloatArray:
        """Total potential ``U`` at ``points`` ``(N, 2)``."""
        return self.attractive(points)[0] + self.repulsive(points)[0]

    def gradient(self, points: Any) -> FloatArray:
        """``grad U`` at ``points`` ``(N, 2)``; the force is ``F = -grad U`` (slide 3:15)."""
        return self.attractive(points)[1] + self.repulsive(points)[1]


def gradient_descent(field: PotentialField, start: Any) -> PotentialFieldResult:
    """Follow ``-grad U`` from ``start`` (slide 3:15) until goal, local minimum or limit.

    Args:
        field: the potential.
        start: start point [m].

    Returns:
        A :class:`PotentialFieldResult`; ``status`` is ``LOCAL_MINIMUM`` when descent stops
        away from the goal (slide 3:16).

    Raises:
        PlanningError: if ``start`` or the field's goal is out of bounds or inside an obstacle.
    """
    t0 = time.perf_counter()
    o = field.options
    q = field.world.check_free_point(start, "start")
    field.world.check_free_point(field.goal, "goal")  # a goal in an obstacle is never reached
    pts = [q.copy()]
    status = PotentialStatus.ITERATION_LIMIT
    grad = field.gradient(q)[0]
    max_iterations = check_count(o.max_iterations, "max_iterations")
    stall_window = check_count(o.stall_window, "stall_window", minimum=1)
    it = 0
    for it in range(1, max_iterations + 1):
        if np.linalg.norm(q - field.goal) <= o.goal_tolerance:
            status = PotentialStatus.REACHED
            it -= 1
            break
        gn = float(np.linalg.norm(grad))
        if gn <= o.gradient_tolerance:
            status = PotentialStatus.LOCAL_MINIMUM
            it -= 1
            break
        step = -o.step_size * grad
        sn = float(np.linalg.norm(step))
        if sn > o.max_step:
            step *= o.max_step / sn
        q = q + step
        if not field.world.is_free(q)[0]:
            status = PotentialStatus.COLLISION
            pts.append(q.copy())
            break
        pts.append(q.copy())
        grad = field.gradient(q)[0]
        if (
            len(pts) > stall_window
            and np.linalg.norm(pts[-1] - pts[-1 - stall_window]) < o.stall_distance
        ):
            status = PotentialStatus.LOCAL_MINIMUM
            break
    path = np.asarray(pts)
    logger.debug("gradient descent: %s after %d iterations", status.value, it)
    return PotentialFieldResult(
        success=status is PotentialStatus.REACHED,
        status=status,
        path=path,
        potential=field.value(path),
        gradient_norm=float(np.linalg.norm(field.gradient(path[-1])[0])),
        iterations=it,
        time_s=time.perf_counter() - t0,
    )
