"""The kinematic car of slide 3:47 and control-based sampling (slides 3:51-3:52).

State ``q = (x, y, theta)`` [m, m, rad] (reference point: rear axle centre), controls
``u = (v, phi)``: speed [m/s] and steering angle [rad] with ``|phi| <= Phi``::

    xdot = v cos(theta),   ydot = v sin(theta),   thetadot = (v / L) tan(phi)

with wheelbase ``L`` [m]. The car is non-holonomic (``dim u < dim q``, slide 3:46): every
velocity satisfies ``xdot sin(theta) - ydot cos(theta) = 0`` (slide 3:48). For constant
controls the motion is an arc of curvature ``kappa = tan(phi) / L`` and length ``v tau``,
integrated exactly by :func:`taskspace.planning.se2.arc_pose`. The minimum turning radius is
``r = L / tan(Phi)``.

Thread safety: :class:`CarModel` and :class:`ControlSamplingOptions` are immutable values whose
methods are functions of their arguments; a :class:`ControlTree` is plain data built by one planner
call, not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_vector, check_count, check_finite, check_positive
from taskspace.errors import InvalidInputError, LimitError, PlanningError, UnknownNameError
from taskspace.planning.polygon_world import PolygonWorld
from taskspace.planning.se2 import arc_pose, wrap_angle

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class CarModel:
    """Kinematic car (slide 3:47) with a disc-cover footprint for collision checks.

    Attributes:
        wheelbase: ``L`` [m].
        max_steering: ``Phi`` [rad], in ``(0, pi/2)``.
        max_speed: largest ``|v|`` [m/s].
        footprint_offsets: positions of the footprint discs along the car axis, measured
            forward from the reference point [m].
        footprint_radius: radius of every footprint disc [m] (about half the car width).
    """

    wheelbase: float = 2.5
    max_steering: float = 0.6
    max_speed: float = 1.0
    footprint_offsets: tuple[float, ...] = (-0.4, 0.9, 2.2)
    footprint_radius: float = 0.9

    def __post_init__(self) -> None:
        check_positive(self.wheelbase, "wheelbase")
        check_positive(self.max_speed, "max_speed")
        check_positive(self.footprint_radius, "footprint_radius")
        if not 0.0 < self.max_steering < 0.5 * math.pi:
            raise InvalidInputError(
                f"max_steering must be in (0, pi/2) rad, got {self.max_steering}"
            )

    @property
    def turning_radius(self) -> float:
        """Minimum turning radius ``r = L / tan(Phi)`` [m]."""
        return self.wheelbase / math.tan(self.max_steering)

    def check_controls(self, u: Any) -> FloatArray:
        """Validate controls ``(v, phi)`` against ``|v| <= v_max`` and ``|phi| <= Phi``.

        Raises:
            LimitError: if a control is out of its limits.
        """
        c = np.asarray(u, dtype=float)
        if c.shape[-1] != 2:
            raise InvalidInputError(f"controls must have last dimension 2, got shape {c.shape}")
        lim = np.array([self.max_speed, self.max_steering])
        bad = np.abs(c) > lim * (1 + 1e-12)
        if np.any(bad):
            idx = [int(i) for i in np.flatnonzero(np.any(bad.reshape(-1, 2), axis=0))]
            raise LimitError(
                f"controls (v, phi) exceed |v| <= {self.max_speed} m/s, "
                f"|phi| <= {self.max_steering} rad",
                idx,
                c,
                -lim,
                lim,
            )
        return c

    def dynamics(self, q: Any, u: Any) -> FloatArray:
        """``qdot = (v cos theta, v sin theta, v tan(phi) / L)`` (slide 3:47), vectorised.

        Args:
            q: state(s) ``(..., 3)`` [m, m, rad].
            u: control(s) ``(..., 2)`` ``(v [m/s], phi [rad])``.

        Returns:
            ``qdot`` ``(..., 3)`` [m/s, m/s, rad/s].
        """
        q = np.asarray(q, dtype=float)
        u = self.check_controls(u)
        v, phi = u[..., 0], u[..., 1]
        th = q[..., 2]
        return np.stack([v * np.cos(th), v * np.sin(th), v * np.tan(phi) / self.wheelbase], axis=-1)

    def integrate(self, q: Any, u: Any, duration: Any) -> FloatArray:
        """Exact state after applying constant controls for ``duration`` [s], vectorised.

        The arc ``s = v tau`` with curvature ``kappa = tan(phi) / L`` (see
        :func:`~taskspace.planning.se2.arc_pose`); the heading is wrapped to ``[-pi, pi)``.
        """
        u = self.check_controls(u)
        duration = np.asarray(duration, float)
        check_finite(duration, "duration")
        out = arc_pose(q, np.tan(u[..., 1]) / self.wheelbase, u[..., 0] * duration)
        out[..., 2] = wrap_angle(out[..., 2])
        return out

    def footprint_centers(self, poses: Any) -> FloatArray:
        """Centres ``(N, K, 2)`` of the footprint discs for poses ``(N, 3)``."""
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        off = np.asarray(self.footprint_offsets, dtype=float)
        c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
        return np.stack(
            [p[:, None, 0] + off[None] * c[:, None], p[:, None, 1] + off[None] * s[:, None]],
            axis=-1,
        )

    def poses_free(self, world: PolygonWorld, poses: Any) -> npt.NDArray[np.bool_]:
        """Whether each pose's footprint discs are in bounds and clear of obstacles.

        A disc of radius ``rho`` centred at ``c`` is free iff the signed distance of ``c``
        to the obstacles is at least ``rho`` and it lies ``rho`` inside the bounds.
        """
        centers = self.footprint_centers(poses)
        n, k, _ = centers.shape
        flat = centers.reshape(-1, 2)
        rho = self.footprint_radius
        ok = world.signed_distance(flat) >= rho
        if world.bounds is not None:
            x0, y0, x1, y1 = world.bounds
            ok &= (
                (flat[:, 0] >= x0 + rho)
                & (flat[:, 0] <= x1 - rho)
                & (flat[:, 1] >= y0 + rho)
                & (flat[:, 1] <= y1 - rho)
            )
        return np.asarray(ok.reshape(n, k).all(axis=1))


def lateral_velocity(q: Any, qdot: Any) -> FloatArray:
    """Non-holonomic constraint of slide 3:48: ``xdot sin(theta) - ydot cos(theta)``.

    Zero for every velocity the car can produce ("a car cannot move directly lateral").
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qdot, dtype=float)
    return np.asarray(qd[..., 0] * np.sin(q[..., 2]) - qd[..., 1] * np.cos(q[..., 2]))


@dataclass(frozen=True, kw_only=True)
class ControlSamplingOptions:
    """Settings of :func:`grow_control_tree` (slide 3:51).

    Attributes:
        n_nodes: number of tree nodes to add (an integer >= 0).
        max_attempts: number of sampled motions (attempts may collide; an integer >= 0).
        duration: ``(min, max)`` duration ``tau`` of one motion [s].
        allow_reverse: sample negative speeds too.
        steering: ``"both"`` or ``"left_only"`` (the "only left-steering" car of slide 3:55).
        collision_step: spacing of collision checks along a motion [m].
        seed: random seed used when no ``rng`` is passed.
    """

    n_nodes: int = 500
    max_attempts: int = 5000
    duration: tuple[float, float] = (0.5, 2.0)
    allow_reverse: bool = True
    steering: str = "both"
    collision_step: float = 0.1
    seed: int = 0


@dataclass
class ControlTree:
    """A tree grown by control-based sampling.

    Attributes:
        success: ``True`` if ``n_nodes`` nodes were added.
        nodes: poses ``(n, 3)``.
        parents: parent index of every node (``-1`` for the root).
        controls: ``(v, phi, tau)`` of the motion that created each node (root: zeros).
        attempts: sampled motions.
        collisions: motions rejected by the collision check.
        time_s: wall-clock time [s].
    """

    success: bool
    nodes: FloatArray
    parents: npt.NDArray[np.int64]
    controls: FloatArray
    attempts: int
    collisions: int
    time_s: float = field(default=0.0)


def sample_motion(
    model: CarModel, q: FloatArray, u: FloatArray, duration: float, step: float
) -> FloatArray:
    """Poses along the constant-control motion from ``q``, every ``step`` metres (both ends)."""
    dist = abs(float(u[0])) * duration
    n = max(math.ceil(dist / step), 1)
    taus = np.linspace(0.0, duration, n + 1)
    return model.integrate(np.broadcast_to(q, (n + 1, 3)), np.broadcast_to(u, (n + 1, 2)), taus)


def grow_control_tree(
    model: CarModel,
    world: PolygonWorld,
    start: Any,
    *,
    options: ControlSamplingOptions | None = None,
    rng: np.random.Generator | None = None,
) -> ControlTree:
    """Control-based sampling (slide 3:51): random node, random controls, integrate, keep.

    1. select a node ``q`` of the tree uniformly; 2. pick ``v in {+v_max, -v_max}``,
    ``phi ~ U(-Phi, Phi)`` and ``tau ~ U(tau_min, tau_max)``; 3. integrate exactly;
    4. add the end pose if the whole motion is collision-free.

    Args:
        model: the car.
        world: obstacles with bounds.
        start: root pose ``(x, y, theta)`` [m, m, rad].
        options: settings.
        rng: random generator (default: ``np.random.default_rng(options.seed)``).

    Returns:
        A :class:`ControlTree`.
    """
    t0 = time.perf_counter()
    opts = options or ControlSamplingOptions()
    n_nodes = check_count(opts.n_nodes, "n_nodes")
    max_attempts = check_count(opts.max_attempts, "max_attempts")
    rng = rng if rng is not None else np.random.default_rng(opts.seed)
    q0 = as_vector(start, 3, "start")
    if not model.poses_free(world, q0)[0]:
        raise PlanningError(f"start pose {tuple(q0)} is in collision or out of bounds")
    if opts.steering not in ("both", "left_only"):
        raise UnknownNameError("steering", opts.steering, ["both", "left_only"])
    nodes = [q0]
    parents = [-1]
    controls = [np.zeros(3)]
    attempts = collisions = 0
    lo = 0.0 if opts.steering == "left_only" else -model.max_steering
    while len(nodes) < n_nodes + 1 and attempts < max_attempts:
        attempts += 1
        i = int(rng.integers(len(nodes)))
        v = model.max_speed * (rng.choice([-1.0, 1.0]) if opts.allow_reverse else 1.0)
        u = np.array([v, rng.uniform(lo, model.max_steering)])
        tau = float(rng.uniform(*opts.duration))
        poses = sample_motion(model, nodes[i], u, tau, opts.collision_step)
        if not np.all(model.poses_free(world, poses)):
            collisions += 1
            continue
        nodes.append(poses[-1])
        parents.append(i)
        controls.append(np.array([u[0], u[1], tau]))
    return ControlTree(
        success=len(nodes) == opts.n_nodes + 1,
        nodes=np.asarray(nodes),
        parents=np.asarray(parents, dtype=np.int64),
        controls=np.asarray(controls),
        attempts=attempts,
        collisions=collisions,
        time_s=time.perf_counter() - t0,
    )
