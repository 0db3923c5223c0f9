"""Optimization objectives of the optimal planners (OMPL's ``OptimizationObjective``).

An objective is an additive path cost ``J(path) = sum_i c(q_i, q_{i+1})`` with a motion
cost ``c >= 0`` that is symmetric (``c(a, b) = c(b, a)``, so roadmaps are undirected) and an
admissible lower bound ``c_hat(a, b) <= c(a, b)`` of the cost of *any* path from ``a`` to
``b`` (the heuristic of BIT* and of informed pruning):

* :class:`PathLength`: ``c(a, b) = |W (b - a)|`` with ``W = diag(w)``, ``w > 0`` (the
  Euclidean length for ``w = 1``); ``c_hat = c`` (a straight line is the shortest path in a
  norm);
* :class:`Clearance`: ``c(a, b) = integral_0^L 1 / (epsilon + d(q(s))) ds`` along the straight
  segment (``d``: distance to the nearest obstacle [m], ``L = |b - a|``), by the trapezoidal
  rule on points at most ``resolution`` apart (OMPL's ``StateCostIntegralObjective``); paths
  that keep away from obstacles cost less per unit length; ``c_hat = L / (epsilon + d_max)``;
* :class:`MechanicalWork`: ``c(a, b) = sum_k |tau_g(m_k) . (p_{k+1} - p_k)|`` over pieces
  ``p_k -> p_{k+1}`` at most ``resolution`` long of the straight segment, ``tau_g`` the
  gravity torque (``pinocchio.computeGeneralizedGravity``) at each piece's midpoint ``m_k``:
  the midpoint-rule approximation of the absolute work against gravity
  ``integral |tau_g(q) . dq|`` (work done and work recovered both count); ``c_hat = 0``;
* :class:`WeightedSum`: ``c = sum_k lambda_k c_k`` (``lambda_k > 0``), ``c_hat = sum_k lambda_k
  c_hat_k`` (OMPL's ``MultiOptimizationObjective``).

On a joint-manifold space (continuous joints, planar or floating bases: the space's
:class:`~taskspace.planning.joint_manifold.JointManifold`) the planners take every objective
through :meth:`OptimizationObjective.on_manifold`, which evaluates it along the space's
edges, the geodesics ``q(t) = q0 (+) t (q1 (-) q0)``: :class:`PathLength` is
``|W (q1 (-) q0)|`` with ``W`` over the ``nv`` velocity coordinates (unit weights by default;
``objective=None`` is the space's own metric), :class:`Clearance` integrates over the
geodesic's points with ``ds`` in the space's metric, :class:`MechanicalWork` sums
``|tau_g(m_k) . (p_{k+1} (-) p_k)|`` over points and midpoints of the geodesic (Pinocchio's
``interpolate`` and ``difference`` on the robot's model, ``nq != nv`` allowed), and
:class:`WeightedSum` combines its terms' manifold forms. An objective of another class is
refused there unless it overrides :meth:`~OptimizationObjective.on_manifold`.

Thread safety: the objectives keep only the data given at construction; :class:`MechanicalWork`
evaluates each gravity torque in one Pinocchio call on its own data, whose result is copied out
(the bindings hold the GIL during the call). They may therefore be shared by threads, as far as the
functions they wrap (``distances``, ``clearance``) are safe to call from them.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import _to_float, as_vector, check_positive
from taskspace.errors import InvalidInputError
from taskspace.model.robot import interpolate_configurations
from taskspace.planning.configuration_space import (
    _MAX_INTERPOLATED_BYTES,
    FloatArray,
    as_path,
)


class OptimizationObjective(abc.ABC):
    """An additive, symmetric path cost with an admissible lower bound (see the module)."""

    @abc.abstractmethod
    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Costs ``c(q0_i, q1_i)`` of the straight motions between rows, shape (n,).

        Args:
            q0: start configurations, shape (n, d) (or (d,), broadcast against ``q1``).
            q1: end configurations, shape (n, d) (or (d,)).
        """

    def cost_lower_bounds(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Admissible bounds ``c_hat(q0_i, q1_i)`` on the cost of any path, shape (n,).

        The default is 0 (always admissible, no guidance).
        """
        a, _ = np.broadcast_arrays(np.atleast_2d(q0), np.atleast_2d(q1))
        return np.zeros(a.shape[0])

    @property
    def is_euclidean_length(self) -> bool:
        """True when the cost is the plain Euclidean path length (informed ellipsoid sampling)."""
        return False

    @property
    def bound_is_exact(self) -> bool:
        """True when ``cost_lower_bounds`` equals ``motion_costs`` (a metric length)."""
        return False

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """This objective along the geodesics of a joint manifold (see the module).

        The default refuses: a cost written for straight lines in coordinates would be taken
        along the wrong path (and in meaningless coordinates: cos and sin of an angle, a
        quaternion). Subclasses that can evaluate themselves on the manifold override it.

        Raises:
            InvalidInputError: always, naming the class.
        """
        raise InvalidInputError(
            f"{type(self).__name__} is evaluated on straight lines in coordinates; on a "
            "joint-manifold space (continuous joints, planar or floating bases) use PathLength, "
            "Clearance, MechanicalWork, WeightedSum of them, objective=None (the space's "
            "metric), or override on_manifold"
        )

    def motion_cost(self, q0: Any, q1: Any) -> float:
        """Cost of one straight motion ``q0 -> q1`` (finite vectors of one size).

        Raises:
            InvalidInputError: not finite vectors of the same size.
        """
        if not (
            q0.__class__ is np.ndarray
            and q1.__class__ is np.ndarray
            and q0.dtype == np.float64
            and q1.dtype == np.float64
            and q0.ndim == 1
            and q0.shape == q1.shape
        ):  # (float vectors, the planners' calls, skip the conversion)
            q0 = as_vector(q0, None, "q0")
            q1 = as_vector(q1, q0.size, "q1")
        cost = float(self.motion_costs(q0[None, :], q1[None, :])[0])
        if not math.isfinite(cost):  # NaN or inf coordinates: say so rather than return it
            as_vector(q0, None, "q0")
            as_vector(q1, None, "q1")
        return cost

    def path_cost(self, path: Any) -> float:
        """``J(path) = sum_i c(q_i, q_{i+1})`` of a waypoint path, shape (m, d), ``m >= 1``.

        The path is read by :func:`~taskspace.planning.configuration_space.as_path`: a 1-D
        array is refused as ambiguous (``m`` waypoints of a 1-D space, or one waypoint), as
        are NaN or inf and a path without waypoints (a failed plan's ``(0, d)`` path has no
        cost; its ``PlannerResult.cost`` is ``inf``). One waypoint costs 0.

        Raises:
            InvalidInputError: not a finite (m, d) path with ``m >= 1``.
        """
        arr = as_path(path, None)
        if arr.shape[0] < 2:
            return 0.0
        return float(self.motion_costs(arr[:-1], arr[1:]).sum())


def _pairs(q0: FloatArray, q1: FloatArray) -> tuple[FloatArray, FloatArray]:
    a, b = np.broadcast_arrays(np.atleast_2d(q0), np.atleast_2d(q1))
    return a, b


def piece_counts(
    lengths: FloatArray, resolution: float, dim: int, who: str
) -> npt.NDArray[np.int64]:
    """Pieces per segment, ``max(1, ceil(L / resolution))``, of segments cut for a quadrature.

    Args:
        lengths: the segments' lengths [rad or m].
        resolution: the largest piece length [rad or m] (``inf``: one piece per segment).
        dim: coordinates per point (for the memory bound).
        who: the objective's name, for the messages.

    Raises:
        InvalidInputError: a length that is not finite (coordinates so large that their
            difference overflows), or more points than fit in 2 GiB (a resolution far too
            small for the lengths) rather than a count that overflows int64 and silently
            becomes one piece.
    """
    if not np.all(np.isfinite(lengths)):
        raise InvalidInputError(
            f"{who}: a segment length is not finite (configurations too far apart: their "
            "difference overflows a float)"
        )
    ratios = lengths / resolution
    total = float(ratios.sum()) + 2.0 * ratios.size
    if not total * max(dim, 1) * 8.0 <= _MAX_INTERPOLATED_BYTES:
        raise InvalidInputError(
            f"{who}: resolution={resolution:g} would cut the segments (total length "
            f"{float(lengths.sum()):.3g}) into about {total:.3g} pieces of {dim} coordinates "
            "(more than 2 GiB); use a larger resolution"
        )
    return np.maximum(1, np.ceil(ratios - 1e-12).astype(np.int64))


class PathLength(OptimizationObjective):
    """Path length ``sum_i |W (q_{i+1} - q_i)|`` in the weighted metric ``W = diag(w)``.

    Args:
        weights: per-coordinate weights ``w_j > 0`` (size d; ``None``: all 1, the Euclidean
            length) [1 per rad or per m].
    """

    def __init__(self, weights: Any = None) -> None:
        self.weights: FloatArray | None = None
        if weights is not None:
            w = as_vector(weights, None, "weights")
            if np.any(w <= 0):
                raise InvalidInputError(f"weights must all be > 0, got {w.tolist()}")
            self.weights = w

    @property
    def is_euclidean_length(self) -> bool:
        """True for unit weights."""
        return self.weights is None or bool(np.all(self.weights == 1.0))

    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """``|W (q1 - q0)|`` per row."""
        a, b = _pairs(q0, q1)
        diff = b - a
        if self.weights is not None:
            if self.weights.size != diff.shape[1]:
                raise InvalidInputError(
                    f"PathLength has {self.weights.size} weights for configurations of size "
                    f"{diff.shape[1]}"
                )
            diff = diff * self.weights
        return np.sqrt(np.einsum("ij,ij->i", diff, diff))

    def cost_lower_bounds(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """The motion cost itself (a straight line is shortest in any norm)."""
        return self.motion_costs(q0, q1)

    @property
    def bound_is_exact(self) -> bool:
        """True."""
        return True

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """``|W (q1 (-) q0)|``: the weights are over the ``nv`` velocity coordinates.

        Raises:
            InvalidInputError: weights whose size is not the manifold's ``nv``.
        """
        weights = self.weights
        nv = int(manifold.nv)
        if weights is not None and weights.size != nv:
            raise InvalidInputError(
                f"PathLength on a joint-manifold space: {weights.size} weights, the manifold "
                f"has {nv} velocity coordinates (weights are per velocity coordinate there)"
            )
        w = np.ones(nv) if weights is None else weights

        def distances(a: FloatArray, b: FloatArray) -> FloatArray:
            diff = manifold.difference(a, b) * w
            return np.sqrt(np.einsum("ij,ij->i", diff, diff))

        return MetricLength(distances)


class MetricLength(OptimizationObjective):
    """Path length in a given metric: ``c(a, b) = distances(a, b)`` (e.g. a joint manifold's).

    Args:
        distances: ``distances(Q0, Q1) -> (n,)``, a symmetric metric between rows, for which
            the straight local path is a shortest path (so ``c_hat = c``), e.g.
            :meth:`~taskspace.planning.joint_manifold.JointManifold.distances`.
    """

    def __init__(self, distances: Callable[[FloatArray, FloatArray], Any]) -> None:
        if not callable(distances):
            raise InvalidInputError(
                "distances must be a function (Q0 (n, d), Q1 (n, d)) -> distances (n,), got "
                f"{type(distances).__name__}"
            )
        self.distances = distances

    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """``distances(q0, q1)``.

        Raises:
            InvalidInputError: ``distances`` returned other than ``n`` finite values ``>= 0``
                (a metric; a negative or NaN cost would corrupt every comparison of the
                planners and ``path_cost``).
        """
        a, b = _pairs(q0, q1)
        d = np.asarray(self.distances(a, b), dtype=np.float64)
        if d.size != a.shape[0]:
            raise InvalidInputError(
                f"MetricLength: distances returned {d.size} values for {a.shape[0]} pairs"
            )
        d = d.reshape(a.shape[0])
        if not np.all(d >= 0.0) or not np.all(np.isfinite(d)):
            bad = np.flatnonzero(~((d >= 0.0) & np.isfinite(d)))
            raise InvalidInputError(
                "MetricLength: distances must be finite and >= 0 (a metric), got "
                f"{d[bad[:3]].tolist()} at pairs {bad[:3].tolist()}"
            )
        return d

    def cost_lower_bounds(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """The motion cost (geodesics are shortest)."""
        return self.motion_costs(q0, q1)

    @property
    def bound_is_exact(self) -> bool:
        """True."""
        return True

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """Itself (its ``distances`` are given)."""
        return self


class Clearance(OptimizationObjective):
    """Cost integral of ``1 / (epsilon + d(q))`` along the path: keep away from obstacles.

    Args:
        clearance: ``clearance(Q) -> d``, the distance [m] of each row of ``Q`` (shape
            (n, d)) to the nearest obstacle (negative inside). For a robot, e.g.
            ``lambda Q: np.array([checker.distance(q)[0] for q in Q])`` on convex hulls.
        epsilon: ``epsilon > 0`` [m]; distances are clipped at 0 first, so the integrand is
            at most ``1 / epsilon``.
        resolution: largest spacing of the points of the trapezoidal rule along a segment
            [rad or m].
        max_clearance: an upper bound ``d_max`` of ``d`` over the space [m], for the lower
            bound ``c_hat = L / (epsilon + d_max)`` (``inf``: ``c_hat = 0``).
    """

    def __init__(
        self,
        clearance: Callable[[FloatArray], Any],
        *,
        epsilon: float = 0.01,
        resolution: float = 0.05,
        max_clearance: float = math.inf,
    ) -> None:
        if not callable(clearance):
            raise InvalidInputError("clearance must be a function Q (n, d) -> distances (n,)")
        self.clearance = clearance
        self.epsilon = check_positive(epsilon, "epsilon")
        self.resolution = check_positive(resolution, "resolution")
        d_max = _to_float(max_clearance, "max_clearance")  # (refuses bools and text)
        if not d_max > 0:
            raise InvalidInputError(f"max_clearance must be > 0 [m], got {max_clearance!r}")
        self.max_clearance = d_max
        self._manifold: Any = None

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """The integral along the manifold's geodesics, ``ds`` in its metric (a copy)."""
        bound = Clearance(
            self.clearance,
            epsilon=self.epsilon,
            resolution=self.resolution,
            max_clearance=self.max_clearance,
        )
        bound._manifold = manifold
        return bound

    def _segments(self, a: FloatArray, b: FloatArray) -> tuple[Any, ...]:
        """Lengths, piece counts, points (all segments), their owner and index ``k``."""
        m = self._manifold
        lengths = np.linalg.norm(b - a, axis=1) if m is None else m.distances(a, b)
        counts = piece_counts(lengths, self.resolution, a.shape[1], "Clearance")
        owner = np.repeat(np.arange(a.shape[0]), counts + 1)
        starts = np.concatenate([[0], np.cumsum(counts + 1)[:-1]])
        k = np.arange(owner.size) - starts[owner]
        if m is None:
            t = (k / counts[owner])[:, None]
            points = a[owner] + t * (b[owner] - a[owner])
        else:  # the geodesic's points (pinocchio.interpolate), segment by segment
            points = np.vstack(
                [
                    m.interpolate(a[i], b[i], np.arange(n + 1) / n)
                    for i, n in enumerate(counts.tolist())
                ]
            )
        return lengths, counts, points, owner, k

    def _integrand(self, points: FloatArray) -> FloatArray:
        d = np.asarray(self.clearance(points), dtype=np.float64).reshape(points.shape[0])
        if not np.all(np.isfinite(d)):
            raise InvalidInputError("clearance returned a value that is not finite")
        if self.max_clearance < math.inf and np.any(d > self.max_clearance):
            # c_hat = L / (epsilon + d_max) would exceed costs: BIT*'s heuristic, informed
            # pruning and the optimum test would cut the optimal path without a word
            raise InvalidInputError(
                f"clearance returned {float(d.max()):g} m > max_clearance="
                f"{self.max_clearance:g} m: max_clearance must bound every clearance (the "
                "cost lower bound L / (epsilon + max_clearance) is then admissible)"
            )
        return 1.0 / (self.epsilon + np.maximum(d, 0.0))

    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Trapezoidal ``sum_k (L / n) (f(p_k) + f(p_{k+1})) / 2`` on each segment."""
        a, b = _pairs(q0, q1)
        # All points of all segments in one clearance call.
        lengths, counts, points, owner, k = self._segments(a, b)
        f = self._integrand(points)
        weight = np.where((k == 0) | (k == counts[owner]), 0.5, 1.0)
        sums = np.bincount(owner, weights=weight * f, minlength=a.shape[0])
        return np.asarray(sums * lengths / counts, dtype=np.float64)

    def cost_lower_bounds(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """``L / (epsilon + d_max)``, ``L = |q1 - q0|`` (on a manifold: its metric distance)."""
        a, b = _pairs(q0, q1)
        m = self._manifold
        lengths = np.linalg.norm(b - a, axis=1) if m is None else m.distances(a, b)
        return np.asarray(lengths / (self.epsilon + self.max_clearance), dtype=np.float64)


class MechanicalWork(OptimizationObjective):
    """Absolute mechanical work against gravity along the path (see the module docstring).

    ``c(a, b) = sum_k |tau_g(m_k) . (p_{k+1} - p_k)|`` on the straight segment ``a -> b`` cut
    into ``n = max(1, ceil(|b - a| / resolution))`` equal pieces with midpoints ``m_k``. This
    is the midpoint rule for ``integral_0^1 |tau_g(a + t (b - a)) . (b - a)| dt`` [J], exact
    when ``tau_g`` is constant and of error ``O(resolution^2)`` per unit length where the
    integrand keeps its sign; it ignores velocities (quasi-static motion: the inertial and
    Coriolis torques of a timed trajectory are not counted). ``resolution = inf`` gives one
    piece per segment, ``|tau_g((a + b) / 2) . (b - a)|``. The cost is symmetric and ``>= 0``;
    its lower bound is 0 (moving where gravity does no work is free).

    On a model with continuous joints, a planar or a floating base (``nq != nv``) the
    segment is the geodesic ``q(t) = a (+) t (b (-) a)`` (``pinocchio.integrate``), the
    pieces' ends ``p_k = q(k / n)``, midpoints ``m_k = q((k + 1/2) / n)`` and displacements
    ``p_{k+1} (-) p_k`` (``pinocchio.difference``, size ``nv``; ``tau_g`` is the generalized
    gravity force of the same velocity coordinates), ``n`` from the length of ``b (-) a``.
    For a floating base the work of the base's coordinates is the work against gravity of
    moving the whole robot.

    Args:
        robot: the robot, or its ``pinocchio.Model`` (any joint types Pinocchio
            interpolates; the configurations are the model's, size ``nq``).
        resolution: largest length of the pieces of a segment [rad or m] (``inf``: one
            piece).

    Raises:
        InvalidInputError: not a robot or model, or a bad resolution.
    """

    def __init__(self, robot: Any, *, resolution: float = 0.05) -> None:
        model = getattr(robot, "model", robot)
        if not isinstance(model, pin.Model):
            raise InvalidInputError(
                f"MechanicalWork needs a Robot or a pinocchio.Model, got {type(robot).__name__}"
            )
        if isinstance(resolution, (bool, np.bool_)):
            raise InvalidInputError(f"resolution must be > 0 [rad or m], got {resolution!r}")
        self.resolution = (
            math.inf if resolution == math.inf else check_positive(resolution, "resolution")
        )
        self.model = model
        self._data = model.createData()
        self._gravity = pin.computeGeneralizedGravity
        # nq == nv: every joint's configuration is a vector interpolated linearly
        self._euclidean = model.nq == model.nv

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """Itself: it follows its model's geodesics (sizes checked against the manifold).

        Raises:
            InvalidInputError: a manifold of another size than the model.
        """
        if (int(manifold.nq), int(manifold.nv)) != (self.model.nq, self.model.nv):
            raise InvalidInputError(
                f"MechanicalWork: the space's manifold has nq {manifold.nq}, nv {manifold.nv}; "
                f"the model nq {self.model.nq}, nv {self.model.nv} (a locked-joint space "
                "plans a reduced model: give MechanicalWork that model)"
            )
        return self

    def torques(self, q: FloatArray) -> FloatArray:
        """Gravity torques ``tau_g(q_i)`` of each row [N m or N], shape (n, nv)."""
        rows = np.atleast_2d(np.asarray(q, dtype=np.float64))
        return np.array([self._gravity(self.model, self._data, r) for r in rows])

    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Midpoint-rule absolute work on each straight segment [J]."""
        a, b = _pairs(q0, q1)
        if a.shape[1] != self.model.nq:
            raise InvalidInputError(
                f"MechanicalWork: configurations must have size {self.model.nq}, got {a.shape[1]}"
                " (a locked-joint space plans a reduced model: give MechanicalWork "
                "space.planning_model)"
            )
        if not self._euclidean:
            return self._manifold_costs(a, b)
        lengths = np.linalg.norm(b - a, axis=1)
        counts = self._counts(lengths)
        owner = np.repeat(np.arange(a.shape[0]), counts)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        k = np.arange(owner.size) - starts[owner]
        t = ((k + 0.5) / counts[owner])[:, None]
        step = (b - a)[owner] / counts[owner][:, None]
        tau = self.torques(a[owner] + t * (b - a)[owner])
        work = np.abs(np.einsum("ij,ij->i", tau, step))
        return np.asarray(np.bincount(owner, weights=work, minlength=a.shape[0]), dtype=np.float64)

    def _counts(self, lengths: FloatArray) -> npt.NDArray[np.int64]:
        if self.resolution == math.inf:
            return np.ones(lengths.shape[0], dtype=np.int64)
        return piece_counts(lengths, self.resolution, self.model.nq, "MechanicalWork")

    def _manifold_costs(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """The work along the model's geodesics (Pinocchio's interpolate and difference)."""
        model = self.model
        a = np.array([pin.normalize(model, x) for x in a])  # Pinocchio's SO(2) difference is
        b = np.array([pin.normalize(model, y) for y in b])  # right on normalized inputs only
        lengths = np.array(
            [float(np.linalg.norm(pin.difference(model, x, y))) for x, y in zip(a, b)]
        )
        out = np.empty(a.shape[0])
        for i, n in enumerate(self._counts(lengths).tolist()):
            # the robot's interpolation a (+) t (b (-) a) (interpolate_configurations)
            ends = interpolate_configurations(model, a[i], b[i], np.arange(n + 1) / n)
            mids = interpolate_configurations(model, a[i], b[i], (np.arange(n) + 0.5) / n)
            steps = np.array([pin.difference(model, ends[k], ends[k + 1]) for k in range(n)])
            tau = self.torques(np.asarray(mids))
            out[i] = float(np.abs(np.einsum("ij,ij->i", tau, steps)).sum())
        return out


class WeightedSum(OptimizationObjective):
    """``c = sum_k lambda_k c_k`` of several objectives (OMPL's ``MultiOptimizationObjective``).

    Args:
        terms: ``[(lambda_k, objective_k), ...]`` with ``lambda_k > 0``.
    """

    def __init__(self, terms: Sequence[tuple[float, OptimizationObjective]]) -> None:
        if not terms:
            raise InvalidInputError("WeightedSum needs at least one (weight, objective) term")
        checked = []
        for i, term in enumerate(terms):
            if not (isinstance(term, tuple) and len(term) == 2):
                raise InvalidInputError(f"terms[{i}] must be a (weight, objective) tuple")
            weight, objective = term
            if not isinstance(objective, OptimizationObjective):
                raise InvalidInputError(
                    f"terms[{i}]: {type(objective).__name__} is not an OptimizationObjective "
                    "(PathLength, Clearance, MechanicalWork, WeightedSum)"
                )
            checked.append((check_positive(weight, f"terms[{i}] weight"), objective))
        self.terms = checked

    def motion_costs(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Weighted sum of the terms' costs."""
        return np.asarray(sum(w * obj.motion_costs(q0, q1) for w, obj in self.terms))

    def cost_lower_bounds(self, q0: FloatArray, q1: FloatArray) -> FloatArray:
        """Weighted sum of the terms' bounds."""
        return np.asarray(sum(w * obj.cost_lower_bounds(q0, q1) for w, obj in self.terms))

    def on_manifold(self, manifold: Any) -> OptimizationObjective:
        """The weighted sum of the terms' manifold forms."""
        return WeightedSum([(w, obj.on_manifold(manifold)) for w, obj in self.terms])


def space_objective(space: Any, objective: Any) -> OptimizationObjective:
    """The objective of a planner on ``space``.

    :func:`check_objective` for a Euclidean space; on a joint manifold, ``None`` is the path
    length in the space's metric (:class:`MetricLength`) and an objective is taken through
    :meth:`OptimizationObjective.on_manifold` (along the space's geodesics).

    Raises:
        InvalidInputError: not an objective, or one that cannot be evaluated on the
            manifold (see :meth:`OptimizationObjective.on_manifold`).
    """
    manifold = getattr(space, "manifold", None)
    if manifold is None:
        return check_objective(objective)
    if objective is None:
        return MetricLength(manifold.distances)
    return check_objective(objective).on_manifold(manifold)


def optimum_lower_bound(
    objective: OptimizationObjective, start: FloatArray, goals: Sequence[FloatArray], region: Any
) -> float:
    """An admissible bound on the optimal cost: ``min_g c_hat(start, g)`` (``-inf`` for a region).

    A planner whose best cost reaches it (up to rounding) holds an optimal path and may stop.
    """
    if region is not None or not goals:
        return -math.inf
    arr = np.asarray(goals, dtype=np.float64).reshape(len(goals), -1)
    return float(np.min(objective.cost_lower_bounds(start, arr)))


def reached_optimum(cost: float, bound: float) -> bool:
    """``cost <= bound`` up to rounding (relative 1e-9)."""
    return bool(math.isfinite(cost) and cost <= bound * (1 + 1e-9) + 1e-12)


def check_objective(objective: Any) -> OptimizationObjective:
    """``objective``, or the Euclidean :class:`PathLength` for ``None``; refuses other types."""
    if objective is None:
        return PathLength()
    if not isinstance(objective, OptimizationObjective):
        raise InvalidInputError(
            "objective must be an OptimizationObjective (PathLength, Clearance, MechanicalWork, "
            f"WeightedSum), "
            f"got {type(objective).__name__}"
        )
    return objective
