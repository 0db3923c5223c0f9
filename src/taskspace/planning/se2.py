"""SE(2) poses, the metrics of slide 3:58, and exact constant-curvature motion.

A planar pose is ``q = (x, y, theta)`` with position in metres and heading in radians. This
module holds:

* angle wrapping and the two SO(2) metrics of slide 3:58,
  (a) ``|e^{i theta_1} - e^{i theta_2}|`` and (b) ``min(|dtheta|, 2 pi - |dtheta|)``;
* the naive SE(2) metric of slide 3:58, the Euclidean metric on ``(x, y, e^{i theta})``;
* the SO(3) quaternion metric ``min(|r1 - r2|, |r1 + r2|)`` of the same slide;
* :func:`arc_pose`, the exact integral of the car kinematics of slide 3:47 for constant
  curvature (the closed form every Dubins / Reeds-Shepp sampler is built on);
* :class:`CurvePath`, a sequence of constant-curvature segments (``L``, ``S``, ``R``) with
  signed lengths (negative = driving backwards), returned by the Dubins and Reeds-Shepp
  solvers.

Thread safety: :class:`CurvePath` is an immutable value; the functions keep their state local to
the call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._native import planning_kernel
from taskspace._validation import _to_float, as_float_array, as_vector, check_finite, check_positive
from taskspace.errors import InvalidInputError, ShapeError

FloatArray = npt.NDArray[np.float64]


# The compiled planning kernel's functions, bound at the first query (or stand-ins returning
# None, the NumPy path, when the kernel is not built): module globals called directly, not a
# planning_kernel() call and an attribute lookup per query (a single query takes 0.4-1 us).
def _no_kernel(*args: Any) -> None:
    return None


def _bind_kernel() -> None:
    global _native_poses
    kernel = planning_kernel()
    _native_poses = kernel.curve_poses if kernel is not None else _no_kernel


def _first_poses(*args: Any) -> Any:
    _bind_kernel()
    return _native_poses(*args)


_native_poses: Callable[..., Any] = _first_poses


#: Curvature sign of each segment letter: left turns have curvature +1/r, right turns -1/r.
STEER_SIGN: dict[str, int] = {"L": 1, "S": 0, "R": -1}


def wrap_angle(theta: Any) -> Any:
    """Wrap angles to ``[-pi, pi)``.

    Args:
        theta: angle(s) [rad], scalar or array.

    Returns:
        ``(theta + pi) mod 2 pi - pi`` with the same shape as ``theta``.
    """
    return np.mod(np.asarray(theta, dtype=float) + np.pi, 2.0 * np.pi) - np.pi


def angle_distance(theta1: Any, theta2: Any) -> Any:
    """Geodesic SO(2) metric of slide 3:58 (b).

    ``d(theta1, theta2) = min(|theta1 - theta2|, 2 pi - |theta1 - theta2|)`` with the
    difference first reduced to ``[0, 2 pi)``.

    Args:
        theta1: angle(s) [rad].
        theta2: angle(s) [rad], broadcastable with ``theta1``.

    Returns:
        Distance(s) in ``[0, pi]`` [rad].
    """
    d = np.mod(np.abs(np.asarray(theta1, dtype=float) - np.asarray(theta2, dtype=float)), 2 * np.pi)
    return np.minimum(d, 2.0 * np.pi - d)


def angle_chord_distance(theta1: Any, theta2: Any) -> Any:
    """Chordal SO(2) metric of slide 3:58 (a): ``|e^{i theta1} - e^{i theta2}|``.

    Equal to ``2 |sin((theta1 - theta2) / 2)|``.

    Args:
        theta1: angle(s) [rad].
        theta2: angle(s) [rad], broadcastable with ``theta1``.

    Returns:
        Distance(s) in ``[0, 2]`` (dimensionless).
    """
    d = np.asarray(theta1, dtype=float) - np.asarray(theta2, dtype=float)
    return 2.0 * np.abs(np.sin(0.5 * d))


def se2_distance(q1: Any, q2: Any, *, rotation_weight: float = 1.0) -> Any:
    """Naive SE(2) metric of slide 3:58: Euclidean metric on ``(x, y, w e^{i theta})``.

    ``d = sqrt(dx^2 + dy^2 + w^2 |e^{i theta1} - e^{i theta2}|^2)``.

    Args:
        q1: pose(s) ``(..., 3)`` [m, m, rad].
        q2: pose(s) ``(..., 3)``, broadcastable with ``q1``.
        rotation_weight: length scale ``w`` [m] converting the heading chord to metres.

    Returns:
        Distance(s) [m], shape of the broadcast leading dimensions.
    """
    a = np.asarray(q1, dtype=float)
    b = np.asarray(q2, dtype=float)
    if a.shape[-1:] != (3,) or b.shape[-1:] != (3,):
        raise ShapeError("q1/q2", (3,), tuple(a.shape if a.shape[-1:] != (3,) else b.shape))
    check_positive(rotation_weight, "rotation_weight", strict=False)
    chord = angle_chord_distance(a[..., 2], b[..., 2])
    dx = a[..., 0] - b[..., 0]
    dy = a[..., 1] - b[..., 1]
    return np.sqrt(dx * dx + dy * dy + (rotation_weight * chord) ** 2)


def quaternion_distance(r1: Any, r2: Any) -> float:
    """SO(3) metric of slide 3:58 on unit quaternions: ``min(|r1 - r2|, |r1 + r2|)``.

    ``r`` and ``-r`` represent the same rotation, hence the minimum.

    Args:
        r1: unit quaternion (4,).
        r2: unit quaternion (4,).

    Returns:
        Distance in ``[0, sqrt(2)]``.
    """
    a = as_vector(r1, 4, "r1")
    b = as_vector(r2, 4, "r2")
    for name, r in (("r1", a), ("r2", b)):
        if abs(float(np.linalg.norm(r)) - 1.0) > 1e-6:
            raise InvalidInputError(
                f"{name} must be a unit quaternion, |{name}| = {np.linalg.norm(r)}"
            )
    return float(min(np.linalg.norm(a - b), np.linalg.norm(a + b)))


def to_local(start: Any, goal: Any, radius: float) -> tuple[Any, Any, Any]:
    """Express ``goal`` in the frame of ``start``, scaled by ``1 / radius``.

    ``(x, y) = R(-theta_s) (p_g - p_s) / r``, ``phi = theta_g - theta_s``: the normalised
    problem of Dubins and Reeds-Shepp (unit turning radius, start at the origin).

    Args:
        start: start pose(s) ``(..., 3)`` [m, m, rad].
        goal: goal pose(s) ``(..., 3)``, broadcastable.
        radius: turning radius ``r`` [m].

    Returns:
        ``(x, y, phi)`` arrays (dimensionless, dimensionless, rad).
    """
    s = np.asarray(start, dtype=float)
    g = np.asarray(goal, dtype=float)
    dx = g[..., 0] - s[..., 0]
    dy = g[..., 1] - s[..., 1]
    c = np.cos(s[..., 2])
    sn = np.sin(s[..., 2])
    x = (c * dx + sn * dy) / radius
    y = (-sn * dx + c * dy) / radius
    phi = g[..., 2] - s[..., 2]
    return x, y, phi


def arc_pose(q: Any, curvature: Any, s: Any) -> FloatArray:
    """Exact pose after driving a signed arc length ``s`` with constant curvature.

    Integrates the car of slide 3:47 with ``dtheta/ds = kappa`` in closed form::

        theta(s) = theta0 + kappa s
        x(s) = x0 + (sin(theta(s)) - sin(theta0)) / kappa
        y(s) = y0 - (cos(theta(s)) - cos(theta0)) / kappa

    and ``x(s) = x0 + s cos(theta0)``, ``y(s) = y0 + s sin(theta0)`` for ``kappa = 0``.
    Negative ``s`` drives backwards.

    Args:
        q: start pose(s) ``(..., 3)`` [m, m, rad].
        curvature: curvature(s) ``kappa = tan(phi) / L`` [1/m], broadcastable.
        s: signed arc length(s) [m], broadcastable.

    Returns:
        Pose(s) ``(..., 3)``; the heading is not wrapped.
    """
    q = np.asarray(q, dtype=float)
    k = np.asarray(curvature, dtype=float)
    s = np.asarray(s, dtype=float)
    if q.shape[-1:] != (3,):
        raise ShapeError("q", (3,), q.shape)
    for value, name in ((q, "q"), (k, "curvature"), (s, "s")):
        check_finite(value, name)
    return _arc_pose(q, k, s)


def _arc_pose(q: FloatArray, k: FloatArray | float, s: FloatArray | float) -> FloatArray:
    """:func:`arc_pose` of float arrays, unchecked (callers with checked inputs)."""
    th0 = q[..., 2]
    half = 0.5 * k * s
    th = th0 + 2.0 * half
    # sin(a + b) - sin(a) = 2 cos(a + b / 2) sin(b / 2): the chord 2 sin(k s / 2) / k
    # = s sinc(k s / 2) is well conditioned for small and zero curvature.
    chord = s * np.sinc(half / np.pi)
    mid = th0 + half
    x = q[..., 0] + chord * np.cos(mid)
    y = q[..., 1] + chord * np.sin(mid)
    return np.stack(np.broadcast_arrays(x, y, th), axis=-1)


@dataclass(frozen=True)
class CurvePath:
    """A path made of constant-curvature segments (Dubins / Reeds-Shepp word).

    Attributes:
        start: start pose ``(x, y, theta)`` [m, m, rad].
        word: segment letters, e.g. ``("L", "S", "R")``; ``L`` turns left with curvature
            ``+1/radius``, ``R`` right with ``-1/radius``, ``S`` is straight.
        lengths: signed segment lengths [m]; negative means driving backwards.
        radius: turning radius [m].
        family: name of the formula family that produced the path, with directions,
            e.g. ``"L+R-L+"`` (Reeds-Shepp) or ``"LSR"`` (Dubins).
    """

    start: tuple[float, float, float]
    word: tuple[str, ...]
    lengths: tuple[float, ...]
    radius: float
    family: str

    @property
    def length(self) -> float:
        """Total path length ``sum_i |l_i|`` [m]."""
        return float(sum(abs(v) for v in self.lengths))

    @property
    def curvatures(self) -> tuple[float, ...]:
        """Signed curvature of each segment [1/m]."""
        return tuple(STEER_SIGN[w] / self.radius for w in self.word)

    def segment_starts(self) -> FloatArray:
        """Poses at the start of every segment plus the end pose, shape ``(n + 1, 3)``."""
        poses = np.empty((len(self.word) + 1, 3))
        poses[0] = self.start
        for i, (k, ell) in enumerate(zip(self.curvatures, self.lengths)):
            poses[i + 1] = _arc_pose(poses[i], k, ell)
        return poses

    @property
    def end(self) -> FloatArray:
        """End pose (heading wrapped to ``[-pi, pi)``) [m, m, rad]."""
        q = self.segment_starts()[-1].copy()
        q[2] = float(wrap_angle(q[2]))
        return q

    def pose_at(self, s: Any) -> FloatArray:
        """Exact pose(s) at travelled distance(s) ``s`` in ``[0, length]`` [m].

        Computed by the compiled planning kernel when it is built and ``s`` is a number or a
        1-D float array (same results to rounding). A heading already in ``[-pi, pi)`` is not
        re-wrapped, so that ``pose_at(0)`` is the start pose exactly.

        Args:
            s: distance(s) along the path [m] (absolute arc length, always increasing).

        Returns:
            Pose(s) ``(..., 3)`` with wrapped headings.

        Raises:
            NotFiniteError: NaN or inf in ``s`` (distances outside ``[0, length]`` are
                clipped to it; NaN has no place on the path).
        """
        if not (s.__class__ is float and math.isfinite(s)):
            check_finite(as_float_array(s, "s"), "s")
        out = _native_poses(self.start, self.word, self.lengths, self.radius, s)
        if out is not None:
            return out  # type: ignore[no-any-return]
        return self.pose_at_numpy(s)

    def pose_at_numpy(self, s: Any) -> FloatArray:
        """:meth:`pose_at` in NumPy (the reference of the compiled kernel)."""
        s_arr = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        starts = self.segment_starts()
        abs_len = np.abs(np.asarray(self.lengths, dtype=float))
        cum = np.concatenate([[0.0], np.cumsum(abs_len)])
        idx = np.clip(np.searchsorted(cum, s_arr, side="right") - 1, 0, len(self.word) - 1)
        local = s_arr - cum[idx]
        sign = np.sign(np.asarray(self.lengths, dtype=float))[idx]
        k = np.asarray(self.curvatures)[idx]
        out = _arc_pose(starts[idx], k, sign * local)
        th = out[..., 2]
        out[..., 2] = np.where((th >= -np.pi) & (th < np.pi), th, wrap_angle(th))
        return out

    def sample(self, step: float) -> FloatArray:
        """Poses along the path every ``step`` metres, always including both ends.

        Args:
            step: spacing [m], > 0.

        Returns:
            Array ``(n, 3)`` of poses.
        """
        step = check_positive(step, "step")
        n = max(math.ceil(self.length / step), 1)
        return self.pose_at(np.linspace(0.0, self.length, n + 1))

    def truncated(self, max_length: float) -> CurvePath:
        """The first ``max_length`` metres of this path (the whole path if shorter).

        Args:
            max_length: travelled distance to keep [m], ``>= 0`` (``inf``: the whole path).

        Raises:
            InvalidInputError: ``max_length`` NaN or negative (NaN gave the whole path, a
                negative length an empty one).
        """
        if max_length.__class__ is not float:
            max_length = _to_float(max_length, "max_length")
        if not max_length >= 0.0:
            raise InvalidInputError(
                f"max_length must be >= 0 [m] (inf: the whole path), got {max_length!r}"
            )
        if max_length >= self.length:
            return self
        rest = max_length
        lengths: list[float] = []
        word: list[str] = []
        for w, ell in zip(self.word, self.lengths):
            if rest <= 0.0:
                break
            take = min(abs(ell), rest)
            lengths.append(math.copysign(take, ell))
            word.append(w)
            rest -= take
        return CurvePath(self.start, tuple(word), tuple(lengths), self.radius, self.family)

    def controls(self, wheelbase: float, speed: float = 1.0) -> FloatArray:
        """Piecewise-constant controls of the car of slide 3:47 that drive this path.

        For segment ``i``: speed ``v = speed * sign(l_i)``, steering
        ``phi = atan(L kappa_i)``, duration ``|l_i| / speed``.

        Args:
            wheelbase: car wheelbase ``L`` [m].
            speed: driving speed magnitude [m/s], > 0.

        Returns:
            Array ``(n, 3)`` of ``(v [m/s], phi [rad], duration [s])`` rows.
        """
        check_positive(wheelbase, "wheelbase")
        check_positive(speed, "speed")
        rows = [
            (speed * (1.0 if ell >= 0 else -1.0), math.atan(wheelbase * k), abs(ell) / speed)
            for k, ell in zip(self.curvatures, self.lengths)
        ]
        return np.asarray(rows, dtype=float).reshape(-1, 3)

    def reversed_in_time(self) -> CurvePath:
        """The same geometric path driven from its end back to its start (``l_i -> -l_i``)."""
        end = tuple(float(v) for v in self.segment_starts()[-1])
        return CurvePath(
            (end[0], end[1], end[2]),
            tuple(reversed(self.word)),
            tuple(-v for v in reversed(self.lengths)),
            self.radius,
            self.family,
        )


def check_pose(q: Any, name: str) -> FloatArray:
    """Validate a planar pose ``(x, y, theta)`` and return it as a float vector."""
    return as_vector(q, 3, name)


def pose_arrays(start: Any, goal: Any) -> tuple[FloatArray, FloatArray]:
    """``start`` and ``goal`` as finite float arrays ``(N, 3)``, broadcast against each other.

    Raises:
        ShapeError: not poses of 3 entries.
        NotFiniteError: NaN or inf in a pose (the distances would be inf or NaN).
    """
    s = np.atleast_2d(np.asarray(start, dtype=float))
    g = np.atleast_2d(np.asarray(goal, dtype=float))
    if s.shape[-1] != 3 or g.shape[-1] != 3:
        raise ShapeError("start/goal", (-1, 3), tuple(s.shape if s.shape[-1] != 3 else g.shape))
    check_finite(s, "start")
    check_finite(g, "goal")
    try:
        s, g = np.broadcast_arrays(s, g)
    except ValueError as exc:
        raise InvalidInputError(
            f"start and goal must hold one pose or the same number of poses, got shapes "
            f"{s.shape} and {g.shape}"
        ) from exc
    return s, g


def finite_distances(out: FloatArray) -> FloatArray:
    """``out`` if every distance is finite, else an error (finite poses too large)."""
    if not np.isfinite(out).all():
        raise InvalidInputError(
            "the poses are too far apart for the turning radius: a distance overflows "
            f"({np.count_nonzero(~np.isfinite(out))} of {out.size}); use a larger radius or "
            "smaller coordinates"
        )
    return out
