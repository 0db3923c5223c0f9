"""The configuration space ``Q`` of sampling-based planners and its local planner (slide 3:32).

``Q`` is the box ``[lower, upper]`` of R^d with the Euclidean metric
``d(q, q') = |q - q'|``; ``Q_free`` is decided by a :class:`ValidityChecker`. The local planner
is the straight line ``q(t) = (1 - t) q + t q'``, tested for collisions up to the resolution
``delta`` (slide 3:32): with ``n = ceil(|q' - q| / delta)`` segments the interior points
``t = k / n`` (``k = 1..n-1``, plus ``k = n`` when asked) are checked in *bisection order*
(midpoint first, then the quarter points, ...: the van der Corput order), so that a collision is
found after few checks, and the search stops at the first collision. Points are sent to the
checker in batches of growing size (1, 4, 16, ... up to ``max_batch``), one C++ call per batch.

Lazy planners split the same interior points into a coarse pass (indices that are multiples
of a stride, checked when an edge is created) and a fine pass (the others, checked only when
the edge lies on a candidate path), see :func:`nested_orders`: together they are exactly the
points of the resolution ``delta``.

Thread safety: :class:`ConfigurationSpace` is one per thread (see there); :class:`EdgeCheckOptions`
is immutable.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import (
    as_float_array,
    as_vector,
    check_count,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, PlanningError, ShapeError
from taskspace.model.robot import Robot
from taskspace.model.versioning import ModelFollower
from taskspace.planning.collision_checker import (
    CollisionChecker,
    CollisionCheckerOptions,
    ValidityChecker,
)
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.locked_joints import LockedJointChecker, LockedJoints

FloatArray = npt.NDArray[np.float64]

_FLOAT64 = np.dtype(np.float64)
_UNIT_STRIDE = (_FLOAT64.itemsize,)  # the strides of a contiguous float64 vector
IntArray = npt.NDArray[np.int64]


@lru_cache(maxsize=512)
def bisection_order(n: int) -> IntArray:
    """Interior indices ``1..n-1`` of ``n`` segments in bisection (van der Corput) order.

    Breadth-first over intervals: the midpoint of ``[0, n]`` first, then the midpoints of the
    two halves, and so on. Every interior index appears once.

    Args:
        n: number of segments (``n >= 1``; ``n = 1`` has no interior point).

    Raises:
        InvalidInputError: ``n > 2**30`` (a resolution far too small for the distance: the
            order alone would take gigabytes; the compiled kernel's limit too).
    """
    if n > _MAX_SEGMENTS:
        raise InvalidInputError(
            f"a line cut into {n:.4g} segments (more than 2^30): the resolution is too small "
            "for the distance between these configurations (or the bounds too large); use a "
            "larger resolution"
        )
    # one breadth-first level at a time: the intervals [a, b) of a level in queue order,
    # each with b - a >= 2 giving its midpoint, then its halves [a, mid), [mid, b)
    a = np.zeros(1, dtype=np.int64)
    b = np.full(1, max(int(n), 0), dtype=np.int64)
    levels = []
    while True:
        keep = b - a >= 2
        a, b = a[keep], b[keep]
        if a.size == 0:
            break
        mid = (a + b) // 2
        levels.append(mid)
        a = np.stack([a, mid], axis=1).ravel()
        b = np.stack([mid, b], axis=1).ravel()
    arr = np.concatenate(levels) if levels else np.empty(0, dtype=np.int64)
    arr.flags.writeable = False
    return arr


_MAX_SEGMENTS = 1 << 30

_MAX_INTERPOLATED_BYTES = 1 << 31
"""The largest path :func:`interpolated_counts` lets a subdivision build (2 GiB)."""


def interpolated_counts(
    lengths: list[float], step: float, dim: int, name: str = "resolution"
) -> list[int]:
    """Pieces per segment, ``ceil(length / step)`` (at least 1), of a path cut every ``step``.

    Args:
        lengths: the segments' lengths [rad or m].
        step: the largest distance between the new waypoints (> 0).
        dim: coordinates per waypoint.
        name: the caller's name of ``step``, for the message.

    Raises:
        InvalidInputError: the path would take more than 2 GiB (a step far too small for
            the lengths), rather than numpy's MemoryError.
    """
    ratios = [length / step for length in lengths]
    total = sum(ratios) + len(ratios) + 1.0
    if not total * dim * 8.0 <= _MAX_INTERPOLATED_BYTES:  # (also inf)
        raise InvalidInputError(
            f"{name}={step:g} would cut the path into about {total:.3g} waypoints of {dim} "
            f"coordinates (more than 2 GiB); use a larger {name}"
        )
    return [max(1, math.ceil(r - 1e-12)) for r in ratios]


""":func:`bisection_order`'s largest ``n``."""


@lru_cache(maxsize=1024)
def nested_orders(n: int, stride: int) -> tuple[IntArray, IntArray]:
    """Split the interior indices ``1..n-1`` of ``n`` segments into a coarse and a fine pass.

    The coarse pass holds the multiples of ``stride`` (spacing ``stride`` segments), the fine
    pass every other interior index; both are in bisection order (:func:`bisection_order`), so
    checking the coarse pass and later the fine pass checks every interior point exactly once.

    Args:
        n: number of segments (``n >= 1``).
        stride: coarse spacing in segments (``stride >= 1``; 1 puts every index in the coarse
            pass).

    Returns:
        ``(coarse, fine)`` index arrays.
    """
    stride = max(1, stride)
    n_coarse = max(1, -(-n // stride))
    coarse = bisection_order(n_coarse) * stride
    fine = bisection_order(n)
    if stride > 1:
        fine = fine[fine % stride != 0]
    else:
        fine = fine[:0]
    coarse = np.ascontiguousarray(coarse)
    fine = np.ascontiguousarray(fine)
    coarse.flags.writeable = False
    fine.flags.writeable = False
    return coarse, fine


@dataclass(frozen=True, kw_only=True)
class EdgeCheckOptions:
    """Settings of the straight-line local planner.

    Attributes:
        resolution: largest C-space distance ``delta`` between checked points [rad or m]
            (slide 3:32).
        max_batch: largest number of points sent to the checker in one call.
    """

    resolution: float = 0.03
    max_batch: int = 32


class ConfigurationSpace:
    """Box-bounded configuration space with a validity checker and a straight-line local planner.

    With a :class:`~taskspace.planning.joint_manifold.JointManifold` (robots with continuous
    joints, planar joints, spherical joints or a floating base, or a weighted metric), the
    distance is the manifold's weighted metric ``|W (q1 (-) q0)|``, the "straight line" is
    Pinocchio's interpolation ``q0 (+) t (q1 (-) q0)`` and samples are uniform on the
    manifold; :attr:`is_euclidean` is then False. RRT, RRT-Connect (its Python
    implementation), RRT*, PRM and Lazy PRM (uniform sampling), PRM*, Lazy PRM* and BIT* plan
    on such spaces, and shortcutting and B-spline smoothing work on them; Gaussian and bridge
    sampling refuse them.

    Args:
        lower: lower bounds (size d) [rad or m].
        upper: upper bounds (size d) [rad or m].
        checker: decides ``q in Q_free`` (a :class:`CollisionChecker` or any
            :class:`ValidityChecker`).
        edge: local-planner settings (resolution ``delta``).
        names: coordinate names for error messages.
        manifold: the joint manifold (``None``: the Euclidean box). Its bounds are used and
            ``lower``/``upper`` must equal them.

    Attributes:
        edge_checks: number of local-planner (edge) queries.

    A space built on a robot (:meth:`from_robot`) holds nothing derived from the obstacle
    world besides its :class:`CollisionChecker`, which follows the world's version (see
    there): after ``robot.clear_obstacles()`` / ``robot.add_obstacle(...)`` the same space
    answers for the new world. Results cached outside the space (roadmaps) can record
    :attr:`world_version` and compare it later.

    Thread safety: not thread-safe (counters and the checker's workspaces); one space per
    thread.
    """

    _robot_metric: tuple[Robot, Any, Any, Any]
    """What :meth:`from_robot` was given: robot, weights, base box (spaces built on a robot)."""

    _diameter: tuple[FloatArray, FloatArray, float] | None = None
    """:meth:`bounds_diameter` of read-only bounds."""

    def __init__(
        self,
        lower: Any,
        upper: Any,
        checker: ValidityChecker,
        *,
        edge: EdgeCheckOptions | None = None,
        names: list[str] | None = None,
        manifold: JointManifold | None = None,
    ) -> None:
        self._follower: ModelFollower | None = None
        self.locked: LockedJoints | None = None
        self._set_bounds(lower, upper, manifold)
        self.checker = checker
        self.edge = edge or EdgeCheckOptions()
        check_positive(self.edge.resolution, "resolution")
        # (an integer: 2.5 raised a bare TypeError from slicing at the first edge check)
        check_count(self.edge.max_batch, "max_batch", minimum=1)
        self.names = names or [f"q[{i}]" for i in range(self._lower.size)]
        self.edge_checks = 0

    def _set_bounds(self, lower: Any, upper: Any, manifold: JointManifold | None) -> None:
        lo = as_vector(lower, None, "lower")
        hi = as_vector(upper, lo.size, "upper")
        if np.any(hi <= lo):
            bad = np.flatnonzero(hi <= lo).tolist()
            raise InvalidInputError(f"upper must be > lower in every coordinate; not at {bad}")
        diameter = math.dist(hi.tolist(), lo.tolist())
        if not math.isfinite(diameter * diameter):
            raise InvalidInputError(
                "the bounds are too large: the squared distance between lower and upper "
                f"(nearest-neighbour searches) overflows a float (lower {lo.min():.3g}, "
                f"upper {hi.max():.3g})"
            )
        if manifold is not None:
            with np.errstate(over="ignore", invalid="ignore"):
                metric_diameter = float(manifold.distances(lo, hi)[0])
            if not math.isfinite(metric_diameter * metric_diameter):
                raise InvalidInputError(
                    "the metric weights are too large: the weighted distance between lower "
                    "and upper overflows a float (weights up to "
                    f"{float(manifold.weights.max()):.3g})"
                )
        self._manifold = manifold
        self._lower = lo
        self._upper = hi
        if self._follower is None and manifold is not None and manifold._follower is not None:
            # a manifold that follows a robot: the space's bounds are re-read from it
            self._follower = ModelFollower(
                manifold._follower.robot, "ConfigurationSpace", self._reread_manifold
            )

    def _reread_manifold(self) -> None:
        assert self._manifold is not None
        self._lower, self._upper = self._manifold.lower, self._manifold.upper

    @property
    def lower(self) -> FloatArray:
        """Lower bounds (size d) [rad or m]; a space built on a robot follows its limits."""
        if (f := self._follower) is not None and f.version != f.robot._version:
            f.sync()
        return self._lower

    @property
    def upper(self) -> FloatArray:
        """Upper bounds (size d) [rad or m]; a space built on a robot follows its limits."""
        if (f := self._follower) is not None and f.version != f.robot._version:
            f.sync()
        return self._upper

    @property
    def manifold(self) -> JointManifold | None:
        """The joint manifold, ``None`` for the Euclidean box."""
        if (f := self._follower) is not None and f.version != f.robot._version:
            f.sync()
        return self._manifold

    # The metric and the local paths (distance, interpolate, tangent_step, retract) use
    # ``_manifold`` without the version check: they do not depend on the limits, and a
    # re-derived space keeps the kind of metric (a box stays a box, a manifold keeps its
    # joints and weights; limits that no longer fit the kind are refused by the bounds).

    @property
    def edge_resolution(self) -> float:
        """The local planner's spacing ``delta`` in the space's metric [rad or m].

        ``edge.resolution`` itself, except with metric weights below 1: then
        ``edge.resolution * min(w)``, so that the checked points of an edge are also at most
        ``edge.resolution`` apart in the joints' own coordinates (``|W dq| >= min(w) |dq|``);
        weights of 0.05 spaced them 20 times further apart and planned paths crossed thin
        obstacles between them.
        """
        res = float(self.edge.resolution)
        manifold = self._manifold
        if manifold is None:
            return res
        w_min = float(np.min(manifold.weights))
        return res * w_min if w_min < 1.0 else res

    @property
    def model_version(self) -> int | None:
        """The robot version the bounds are for (``None``: not built on a robot).

        Results kept outside the space (roadmaps) record it and are refused once it differs.
        """
        if self._follower is None:
            return None
        self._follower.sync()
        return self._follower.version

    @classmethod
    def from_robot(
        cls,
        robot: Robot,
        *,
        edge: EdgeCheckOptions | None = None,
        checker_options: CollisionCheckerOptions | None = None,
        base_lower: Any = None,
        base_upper: Any = None,
        weights: Any = None,
        locked_joints: Mapping[str, Any] | None = None,
    ) -> ConfigurationSpace:
        """The configuration space of a robot with a :class:`CollisionChecker`.

        A robot whose joints are all bounded revolute or prismatic joints gives the
        Euclidean joint-limit box; any continuous, planar, spherical or floating joint (or
        ``weights``) gives a space on its :class:`~taskspace.planning.joint_manifold.
        JointManifold`.

        Args:
            robot: the robot and its obstacle world.
            edge: local-planner settings.
            checker_options: collision checker settings.
            base_lower: lower corner of the base translation box [m] (x, y for a planar
                root joint, x, y, z for a floating base); required for such robots.
            base_upper: upper corner of that box [m].
            weights: metric weights per velocity coordinate (size nv, or the free joints'
                velocity size with ``locked_joints``; default 1). Weights below 1 do not
                coarsen the edge checks: see :attr:`edge_resolution`.
            locked_joints: joint name -> value of joints held fixed (see
                :mod:`taskspace.planning.locked_joints`: a number, an angle or ``(cos, sin)``
                for a continuous joint, the joint's ``nq`` coordinates for a planar joint or a
                floating base). The space is then the sub-space of the other joints: its
                configurations (:attr:`dim`, samples, planned paths, trees) are their
                coordinates in the order of ``q``; :meth:`full_configurations` lifts them to
                the robot's ``q`` with the locked values copied exactly, and the collision
                checker sees those full configurations. Starts and goals may be given as
                either (a full one must hold the locked values). The compiled RRT-Connect
                plans such a space (when the free joints are plain bounded joints) on the
                reduced model and geometry, with the exact checker.

        The space follows the robot's limits: after :meth:`Robot.set_limits` its bounds,
        samples and metric are those of the new limits (results kept outside the space,
        such as roadmaps, record :attr:`model_version` and are refused once it changes).

        Raises:
            InvalidInputError: a joint without finite limits that is not continuous, a
                moving base without its translation box, a joint type that cannot be
                planned on (lock it), a bad locked value, every joint locked.
            UnknownNameError: a locked joint name the robot does not have (the valid names
                are listed).
        """
        checker: ValidityChecker = CollisionChecker(robot, checker_options)
        space = cls.__new__(cls)
        space._follower = None
        space.locked = None
        if locked_joints is not None:
            space.locked = LockedJoints(robot._model, locked_joints)
            checker = LockedJointChecker(checker, space.locked)  # type: ignore[arg-type]
        space.checker = checker
        space.edge = edge or EdgeCheckOptions()
        check_positive(space.edge.resolution, "resolution")
        # (an integer: 2.5 raised a bare TypeError from slicing at the first edge check)
        check_count(space.edge.max_batch, "max_batch", minimum=1)
        space.edge_checks = 0

        space._robot_metric = (robot, weights, base_lower, base_upper)
        # rebuilt after Robot.set_limits (a bound method, not a closure: a deep copy of the
        # space re-derives itself, not the original)
        space._follower = ModelFollower(robot, "ConfigurationSpace", space._derive_from_robot)
        return space

    def _derive_from_robot(self) -> None:
        """Bounds, names and metric of :meth:`from_robot` from the robot's current limits."""
        robot, weights, base_lower, base_upper = self._robot_metric
        if self.locked is not None:
            self._derive_locked(robot, weights, base_lower, base_upper)
            return
        manifold = None
        simple = robot.limited_joints_q.size == robot.nq and robot.nq == robot.nv
        simple = simple and not robot.is_floating
        if not simple or weights is not None or base_lower is not None:
            manifold = JointManifold(
                robot, weights=weights, base_lower=base_lower, base_upper=base_upper
            )
            if manifold.is_euclidean and weights is None:
                manifold = None
        lo, hi = robot.lower_limits, robot.upper_limits
        if manifold is not None:
            lo, hi = manifold.lower, manifold.upper
        names = [str(robot._model.names[jid]) for jid in range(1, robot._model.njoints)]
        self._set_bounds(lo, hi, manifold)
        self.names = names if len(names) == lo.size else [f"q[{i}]" for i in range(lo.size)]

    def _derive_locked(self, robot: Robot, weights: Any, base_lower: Any, base_upper: Any) -> None:
        """:meth:`_derive_from_robot` for the free joints (the reduced Pinocchio model)."""
        locked = self.locked
        assert locked is not None
        model = locked.reduced_model(robot._model)
        self._reduced_model = model
        if weights is not None:
            w = np.asarray(weights, dtype=np.float64)
            if w.shape == (locked.nv,):
                weights = w[locked.free_v]
        manifold: JointManifold | None = JointManifold(
            model, weights=weights, base_lower=base_lower, base_upper=base_upper
        )
        assert manifold is not None
        lo, hi = manifold.lower, manifold.upper
        if manifold.is_euclidean and weights is None:
            manifold = None
            lo = np.array(model.lowerPositionLimit, dtype=np.float64)
            hi = np.array(model.upperPositionLimit, dtype=np.float64)
        self._set_bounds(lo, hi, manifold)
        self.names = [
            f"{model.names[j]}" if model.joints[j].nq == 1 else f"{model.names[j]}[{k}]"
            for j in range(1, model.njoints)
            for k in range(model.joints[j].nq)
        ]

    # ------------------------------------------------------------------ locked joints
    @property
    def planning_model(self) -> pin.Model | None:
        """The Pinocchio model whose configurations are this space's points.

        The robot's model for a space built on a robot; with locked joints, the model of the
        free joints with the locked ones welded at their values (``pinocchio.
        buildReducedModel``: same free joints, same bodies and placements), e.g. for
        :class:`~taskspace.planning.MechanicalWork` on the free joints; ``None`` for a space
        not built on a robot.
        """
        if (f := self._follower) is not None and f.version != f.robot._version:
            f.sync()
        if self.locked is not None:
            return self._reduced_model
        metric = getattr(self, "_robot_metric", None)
        return None if metric is None else metric[0].model

    @property
    def full_dim(self) -> int:
        """Size of the robot's configuration (``nq``; :attr:`dim` without locked joints)."""
        return self.dim if self.locked is None else self.locked.nq

    def full_configurations(self, path: Any) -> FloatArray:
        """The robot's configurations of points of this space (rows or one vector).

        With locked joints the free coordinates are written into a copy of the locked
        configuration, so every locked coordinate holds its value exactly; otherwise the
        points are returned (as a float array).
        """
        arr = np.asarray(path, dtype=np.float64)
        if arr.shape[-1:] != (self.dim,):
            raise InvalidInputError(
                f"points of this space have {self.dim} coordinates, got shape {arr.shape}"
            )
        return arr if self.locked is None else self.locked.lift(arr)

    def _free_coordinates(self, q: Any, name: str) -> Any:
        """A full configuration given to a space with locked joints, reduced (else ``q``)."""
        locked = self.locked
        if locked is None:
            return q
        arr = np.asarray(q)
        if arr.shape != (locked.nq,) or not np.issubdtype(arr.dtype, np.number):
            return q
        full = arr.astype(np.float64)
        bad = locked.mismatch(full)
        if bad:
            raise PlanningError(
                f"{name} is a full configuration whose locked joints are not at their values: {bad}"
            )
        return locked.reduce(full)

    # ------------------------------------------------------------------ basics
    @property
    def dim(self) -> int:
        """Size ``d`` of a configuration vector (``nq`` of a robot)."""
        return int(self._lower.size)  # nq: set_limits never changes it

    @property
    def is_euclidean(self) -> bool:
        """True for the Euclidean box (no manifold or a Euclidean one with unit weights)."""
        return self._manifold is None

    @property
    def tangent_dim(self) -> int:
        """Dimension of the space as a manifold (``nv`` of a robot; ``d`` for a box)."""
        return self.dim if self._manifold is None else self._manifold.nv

    def require_euclidean(self, who: str) -> None:
        """Raise unless the space is the Euclidean box (for algorithms that need one).

        Raises:
            InvalidInputError: the space is on a joint manifold.
        """
        if self._manifold is not None:
            raise InvalidInputError(
                f"{who} plans in a Euclidean box and this space is a joint manifold "
                "(continuous, planar, spherical or floating joints, or a weighted metric); "
                "use rrt, rrt_connect, rrt_star, prm or lazy_prm (uniform sampling), prm_star, "
                "lazy_prm_star or bit_star, which plan on the manifold (shortcut_path and "
                "smooth_bspline work on it too)"
            )

    def distance(self, q0: FloatArray, q1: FloatArray) -> float:
        """Metric distance ``d(q0, q1)`` [rad or m] (Euclidean, or the manifold's)."""
        if self._manifold is None:
            diff = q1 - q0
            return math.sqrt(float(diff @ diff))
        return float(self._manifold.distances(q0, q1)[0])

    def distances(self, points: FloatArray, q: FloatArray) -> FloatArray:
        """``d(points_i, q)`` for the rows of ``points``, shape (n,)."""
        if self._manifold is None:
            diff = points - q
            return np.sqrt(np.einsum("ij,ij->i", diff, diff))
        return self._manifold.distances(points, q)

    def path_length(self, path: FloatArray) -> float:
        """Length ``sum_i d(q_i, q_{i+1})`` of a waypoint path in the space's metric [rad or m].

        ``path``: waypoints (m, dim) (a 1-D array as :func:`as_path` reads it; no waypoint:
        length 0).
        """
        arr = np.asarray(path, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != self.dim or not np.isfinite(arr).all():
            arr = as_path(arr, self.dim)  # (refuses NaN and inf: a NaN length was returned)
        if arr.shape[0] < 2:
            return 0.0
        if self._manifold is None:
            return path_length(arr)
        return float(self._manifold.distances(arr[:-1], arr[1:]).sum())

    def tangent_step(self, q: FloatArray, toward: FloatArray) -> FloatArray:
        """``toward (-) q``: the motion from ``q`` to ``toward`` in the tangent space at ``q``.

        ``toward - q`` in the box; Pinocchio's ``difference`` on a manifold (size ``nv``).
        """
        if self._manifold is None:
            return np.asarray(toward - q, dtype=np.float64)
        return self._manifold.difference(q, toward)[0]

    def retract(self, q: FloatArray, step: FloatArray) -> FloatArray:
        """``q (+) step`` (``q + step`` in the box, Pinocchio's ``integrate`` on a manifold)."""
        if self._manifold is None:
            return np.asarray(q + step, dtype=np.float64)
        return np.asarray(pin.integrate(self._manifold._model, q, step), dtype=np.float64)

    def interpolate(self, q0: FloatArray, q1: FloatArray, t: Any) -> FloatArray:
        """Points of the local path ``q0 -> q1`` at fractions ``t`` (shape (len(t), d)).

        ``(1 - t) q0 + t q1`` in the box, Pinocchio's ``interpolate`` on a manifold.
        """
        if self._manifold is None:
            ts = np.atleast_1d(np.asarray(t, dtype=np.float64))
            return np.asarray(q0 + ts[:, None] * (q1 - q0), dtype=np.float64)
        return self._manifold.interpolate(q0, q1, t)

    def bounds_diameter(self) -> tuple[FloatArray, FloatArray, float]:
        """``(lower, upper, |upper - lower|)`` (the distance by ``math.dist`` [rad or m]).

        The distance is kept while the bounds are the same read-only arrays (those of a space
        built on a robot; a planner calls this at every plan).
        """
        lower, upper = self.lower, self.upper
        kept = self._diameter
        if kept is not None and kept[0] is lower and kept[1] is upper:
            return kept
        bounds = (lower, upper, math.dist(upper.tolist(), lower.tolist()))
        if not (lower.flags.writeable or upper.flags.writeable):
            self._diameter = bounds
        return bounds

    @property
    def extent(self) -> float:
        """Diagonal of the box ``|upper - lower|`` [rad or m] (:meth:`bounds_diameter`)."""
        return self.bounds_diameter()[2]

    @property
    def world_version(self) -> int | None:
        """Version of the obstacle world the checker answers for, ``None`` without a world.

        It is :attr:`CollisionChecker.world_version` (the robot's
        :attr:`~taskspace.model.World.version`, the checker having rebuilt itself first if
        the world changed); a checker without a world (:class:`FunctionChecker`) gives
        ``None``.
        """
        version = getattr(self.checker, "world_version", None)
        return None if version is None else int(version)

    @property
    def checks(self) -> int:
        """Configurations evaluated by the checker so far."""
        return int(self.checker.checks)

    def interpolate_path(self, path: Any, resolution: float) -> FloatArray:
        """The path with points of the local paths inserted every ``resolution`` at most.

        Consecutive waypoints of the result are at most ``resolution`` apart in the space's
        metric, on the manifold (:meth:`interpolate`) for a joint-manifold space; the original
        waypoints are kept. ``path``: waypoints (m, dim), read by :func:`as_path` (a 1-D array
        is m waypoints of a 1-D space, or one waypoint).
        """
        arr = as_path(path, self.dim)
        step = check_positive(resolution, "resolution")
        pairs = list(itertools.pairwise(arr))
        counts = interpolated_counts([self.distance(a, b) for a, b in pairs], step, self.dim)
        out = [arr[:1]]
        for (a, b), k in zip(pairs, counts):
            piece = self.interpolate(a, b, np.arange(1, k + 1) / k)
            piece[-1] = b  # exactly (pinocchio.interpolate may return -quaternion at t = 1)
            out.append(piece)
        return np.vstack(out)

    def sample_uniform(self, rng: np.random.Generator, n: int | None = None) -> FloatArray:
        """Uniform samples of the box: shape (d,) if ``n`` is None, else (n, d)."""
        if self.manifold is not None:
            return self.manifold.sample(rng, 1)[0] if n is None else self.manifold.sample(rng, n)
        if n is None:
            return rng.uniform(self.lower, self.upper)
        return rng.uniform(self.lower, self.upper, size=(n, self.dim))

    def outside_limits(self, path: FloatArray) -> npt.NDArray[np.int64]:
        """Rows of ``path`` (shape (m, d)) outside the joint limits, ascending.

        In the box, every coordinate outside ``[lower, upper]``. On a joint manifold the
        translation box of a planar or floating base is only where samples are drawn: the
        geodesics between samples (screw motions) leave it, and the planners' nodes on them
        with it, so only the other bounded coordinates (the joints' limits) count.
        """
        arr = np.atleast_2d(np.asarray(path, dtype=np.float64))
        mask = np.ones(self.dim, dtype=bool)
        if self.manifold is not None:
            mask = self.manifold.bounded_mask()
            for blk in self.manifold.blocks:
                if blk.kind in ("planar", "free_flyer"):
                    n_t = 2 if blk.kind == "planar" else 3
                    mask[blk.idx_q : blk.idx_q + n_t] = False
        bad = ((arr < self.lower) | (arr > self.upper))[:, mask].any(axis=1)
        return np.flatnonzero(bad).astype(np.int64)

    def within_bounds(self, q: FloatArray) -> bool:
        """True if ``lower <= q <= upper``."""
        return bool(np.all(q >= self.lower) and np.all(q <= self.upper))

    def first_invalid(self, configurations: FloatArray) -> int:
        """Index of the first row of ``configurations`` (shape (n, d)) not in Q_free, or -1.

        One checker call that evaluates the rows in order and stops at the first invalid one.
        """
        return self.checker.first_invalid(configurations)

    def is_valid(self, q: FloatArray) -> bool:
        """``q in Q_free`` (one checker call; the bounds are :meth:`within_bounds`).

        NaN entries give ``False``.

        Raises:
            InvalidInputError: ``q`` is not real numbers (complex values were truncated, text
                parsed, ``None`` or a scalar gave an ``IndexError``).
            ShapeError: ``q`` is not a vector of size :attr:`dim`.
        """
        if not (q.__class__ is np.ndarray and q.dtype == np.float64 and q.ndim == 1):
            q = as_float_array(q, "q")
        if q.shape != self._lower.shape:
            raise ShapeError("q", self._lower.shape, tuple(q.shape))
        return self.checker.first_invalid(q[None, :]) < 0

    def check_endpoint(self, q: Any, name: str) -> FloatArray:
        """Validate a start or goal configuration.

        Returns:
            ``q`` as a float vector.

        Raises:
            PlanningError: ``q`` has the wrong size, is not finite, is outside the bounds
                (the message names the coordinates) or is in collision (the message lists the
                colliding pairs).
            StaleModelError: the space's manifold was built from a bare Pinocchio model
                whose limits have changed since (every plan starts with this check).
        """
        if self._manifold is not None and self._manifold._follower is None:
            self._manifold._sync()  # a bare model: its limits are compared, once per plan
        q = self._free_coordinates(q, name)
        try:
            qa = as_vector(q, self.dim, name)
        except InvalidInputError as exc:
            raise PlanningError(f"{name}: {exc}") from exc
        out = np.flatnonzero((qa < self.lower) | (qa > self.upper))
        if out.size:
            details = ", ".join(
                f"{self.names[i]}={qa[i]:.4g} not in [{self.lower[i]:.4g}, {self.upper[i]:.4g}]"
                for i in out.tolist()
            )
            raise PlanningError(f"{name} is outside the joint limits: {details}")
        if self.manifold is not None and self.manifold.unit_error(qa) > 1e-6:
            raise PlanningError(
                f"{name} is not a valid configuration: a quaternion or (cos, sin) pair is not "
                "of unit norm; normalize it (robot.normalize(q) or pinocchio.normalize)"
            )
        if not self.is_valid(qa):
            raise PlanningError(f"{name} is in collision: {self.checker.explain(qa)}")
        return qa

    def endpoint_vector(self, q: Any, name: str) -> FloatArray:
        """``q`` as a float vector of size d, for a planner that checks the rest itself.

        The first half of :meth:`check_endpoint` (the stale-model check, the conversion, the
        size), without the bounds and collision checks: the compiled RRT-Connect makes those
        in its call (and calls :meth:`check_endpoint` for the message when they fail). A
        contiguous float64 array of size d is returned as is (not copied); other inputs are
        converted and must be finite.

        Raises:
            PlanningError: ``q`` has the wrong size, is not real numbers, or (not an array of
                floats) is not finite.
            StaleModelError: as :meth:`check_endpoint`.
        """
        manifold = self._manifold
        if manifold is not None and manifold._follower is None:
            manifold._sync()  # a bare model: its limits are compared, once per plan
        if (
            type(q) is np.ndarray
            and q.dtype is _FLOAT64  # (else the check below)
            and q.strides == _UNIT_STRIDE
            and q.shape == self._lower.shape
            and self.locked is None
        ):
            return q  # a contiguous float64 vector of size d
        q = self._free_coordinates(q, name)
        if (
            type(q) is np.ndarray
            and q.dtype == np.float64
            and q.shape == (self.dim,)
            and q.flags.c_contiguous
        ):
            return q
        try:
            return as_vector(q, self.dim, name)
        except InvalidInputError as exc:
            raise PlanningError(f"{name}: {exc}") from exc

    # ------------------------------------------------------------------ local planner
    def segments(self, q0: FloatArray, q1: FloatArray) -> int:
        """Number of segments ``n = max(1, ceil(d(q0, q1) / delta))``."""
        length = self.distance(q0, q1)
        if not math.isfinite(length):  # (math.ceil's bare ValueError / OverflowError)
            raise InvalidInputError(
                f"the motion's length is not finite ({length}): NaN or inf in q0 or q1, or "
                "configurations so far apart that their distance overflows"
            )
        return max(1, math.ceil(length / self.edge_resolution - 1e-12))

    def motion_valid(self, q0: FloatArray, q1: FloatArray, *, check_end: bool = False) -> bool:
        """Straight-line local planner (slide 3:32): is the segment ``q0 -> q1`` in Q_free?

        Points ``q0 + (k / n)(q1 - q0)`` are checked in bisection order with early exit.
        ``q0`` is assumed valid; ``q1`` is checked only if ``check_end``.
        """
        self.edge_checks += 1
        if check_end:
            if self.checker.first_invalid(q1[None, :]) >= 0:
                return False
        points, bounds = self.edge_points(q0, q1)
        start = 0
        for stop in bounds:
            if self.checker.first_invalid(points[start:stop]) >= 0:
                return False
            start = stop
        return True

    def edge_points(self, q0: FloatArray, q1: FloatArray) -> tuple[FloatArray, list[int]]:
        """The interior points :meth:`motion_valid` checks and its batches.

        Returns:
            The points ``q0 + (k / n)(q1 - q0)``, ``0 < k < n`` (on the manifold for joint
            spaces), in bisection order, and the end row of each checker call: batches of
            1, 4, 16, ... points up to ``edge.max_batch``.
        """
        n = self.segments(q0, q1)
        order = bisection_order(n)
        if order.size == 0:
            return np.empty((0, self.dim)), []
        points = self.interpolate(q0, q1, order / n)
        bounds: list[int] = []
        stop, size, cap = 0, 1, self.edge.max_batch
        while stop < order.size:
            stop = min(order.size, stop + size)
            bounds.append(stop)
            size = min(cap, size * 4)
        return points, bounds

    def path_valid(self, path: Any, *, resolution: float | None = None) -> bool:
        """Every waypoint of ``path`` is inside the bounds and every waypoint and edge in Q_free.

        Args:
            path: waypoints (m, dim), ``m >= 1``, finite (read by :func:`as_path`: a 1-D
                array is m waypoints of a 1-D space or one waypoint).
            resolution: check edges at this resolution instead of the planner's.

        Raises:
            InvalidInputError: not a finite (m, dim) path; an empty path (a failed plan's
                ``(0, d)`` path) is refused rather than called valid.
        """
        arr = as_path(path, self.dim)
        if self.outside_limits(arr).size:  # (a configuration outside the joint limits)
            return False
        if self.checker.first_invalid(arr) >= 0:
            return False
        saved = self.edge
        if resolution is not None:
            self.edge = EdgeCheckOptions(
                resolution=check_positive(resolution, "resolution"), max_batch=saved.max_batch
            )
        try:
            return all(self.motion_valid(arr[i], arr[i + 1]) for i in range(arr.shape[0] - 1))
        finally:
            self.edge = saved


def as_path(path: Any, dim: int | None, name: str = "path") -> FloatArray:
    """Waypoints ``(m, d)``, ``m >= 1``, finite: the one reading of a path by every function.

    A 2-D array holds one waypoint per row. A 1-D array is ambiguous: with ``dim == 1`` its
    ``n`` values are ``n`` waypoints (shape (n, 1)); with ``dim == n`` it is one waypoint
    (shape (1, n)); any other 1-D array, and every 1-D array when the dimension is not known
    (``dim=None``: :func:`~taskspace.planning.interpolate`, :func:`path_length`), is refused.

    Args:
        path: the waypoints.
        dim: coordinates per waypoint (the space's ``dim``, the robot's ``nq``), or ``None``.
        name: the argument's name, for the messages.

    Raises:
        InvalidInputError: not numbers, not finite, no waypoint, a shape other than
            ``(m, dim)`` or a 1-D array it cannot read (the message names the shape to give).
    """
    arr = as_float_array(path, name)
    if arr.ndim == 1 and dim is not None and arr.size > 0 and dim in (1, arr.size):
        arr = arr.reshape(-1, 1) if dim == 1 else arr.reshape(1, -1)
    d = "d" if dim is None else str(dim)
    if arr.ndim == 1:
        n = arr.size
        raise InvalidInputError(
            f"{name} must have shape (m, {d}) (one waypoint of {d} coordinates per row), got a "
            f"1-D array of {n} values, which is ambiguous: give "
            + (
                f"[[q_1], ..., [q_{n}]] (np.reshape(path, (-1, 1))) for {n} waypoints of a 1-D "
                f"space or [[q_1, ..., q_{n}]] for one waypoint of {n} coordinates"
                if dim is None
                else f"an (m, {dim}) array"
            )
        )
    if arr.ndim != 2 or arr.shape[0] == 0 or (dim is not None and arr.shape[1] != dim):
        raise InvalidInputError(
            f"{name} must have shape (m, {d}) with m >= 1 (one waypoint per row), got shape "
            f"{arr.shape}"
        )
    check_finite(arr, name)
    return arr


def path_length(path: FloatArray) -> float:
    """Euclidean length ``sum_i |q_{i+1} - q_i|`` of a waypoint path (m, d) [rad or m].

    Raises:
        InvalidInputError: not a finite (m, d) path (NaN or inf gave a NaN length); a path
            without waypoints, shape (0, d), has length 0.
    """
    arr = np.asarray(path, dtype=float)
    if arr.ndim != 2 or not np.isfinite(arr).all():
        arr = as_path(arr, None)
    if arr.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(arr, axis=0), axis=1).sum())
