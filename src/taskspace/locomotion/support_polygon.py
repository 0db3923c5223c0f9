"""Support polygon of a set of contacts and the static stability test of the CoM.

The support polygon is the convex hull of the contact vertices projected on the (horizontal)
ground: the region where the ground reaction can act (its center of pressure). A standing
robot is statically stable when the ground projection of its center of mass ``c`` lies inside
it; the stability margin is the signed distance

    d(c) = min_i (b_i - a_i^T c_xy),   |a_i| = 1,

to the nearest edge (positive inside), with the polygon as ``{p : a_i^T p <= b_i}``. A single
point or a segment (one point contact, two point contacts, a knife edge) has an empty interior:
its margin is minus the distance to it.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, as_vector, check_finite
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.locomotion.foot import FootGeometry

# Sine of the turn angle below which three hull points count as collinear, and the distance
# (relative to the extent of the points) below which two points count as one.
_COLLINEAR_SINE = 1e-12
_MERGE_DECIMALS = 12


def _pow2_scale(x: FloatArray) -> float:
    """A power of two ``s`` with ``max|x| / s`` in [0.5, 1) (1.0 for all zeros); x / s is exact."""
    m = float(np.max(np.abs(x))) if x.size else 0.0
    return math.ldexp(1.0, math.frexp(m)[1]) if m > 0.0 else 1.0


def _local(points: FloatArray) -> tuple[FloatArray, FloatArray, float, float]:
    """Points in a local frame of unit extent: ``points = (w0 + u * t) * s``.

    ``s`` and ``t`` are powers of two, so that the hull, area, centroid and half-spaces are
    computed without overflow or underflow for any finite coordinates (the differences
    ``w - w0`` stay within [-2, 2] before their own rescaling to [-1, 1]).

    Returns:
        ``(u, w0, s, t)``.
    """
    s = _pow2_scale(points)
    w = points / s
    d = w - w[0]
    t = _pow2_scale(d)
    return d / t, w[0], s, t


def _convex_hull(points: FloatArray) -> FloatArray:
    """Counter-clockwise convex hull of 2-D points (Andrew's monotone chain), no collinear.

    Scale-invariant: the tests run on the points rescaled to unit extent (by powers of two),
    with points closer than 1e-12 of the extent merged and turns below 1e-12 rad taken as
    collinear, so a polygon of 1e-9 m is as well resolved as one of 1 m or 1e200 m. The
    returned vertices are input points, unchanged.
    """
    u = _local(points)[0]
    _, first = np.unique(np.round(u, _MERGE_DECIMALS), axis=0, return_index=True)
    if first.shape[0] <= 2:
        return points[first]
    keep = first[np.lexsort((u[first, 1], u[first, 0]))]
    uk = u[keep]

    def half(order: range) -> list[int]:
        chain: list[int] = []
        for i in order:
            p = uk[i]
            while len(chain) >= 2:
                o, a = uk[chain[-2]], uk[chain[-1]]
                oa, op = a - o, p - o
                cross = oa[0] * op[1] - oa[1] * op[0]
                if cross > _COLLINEAR_SINE * math.hypot(*oa) * math.hypot(*op):
                    break
                chain.pop()
            chain.append(i)
        return chain

    n = uk.shape[0]
    lower, upper = half(range(n)), half(range(n - 1, -1, -1))
    return points[keep[np.array(lower[:-1] + upper[:-1])]]


def _segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> float:
    """Distance [m] from ``p`` to the segment ``ab`` (no overflow for any finite input)."""
    s = _pow2_scale(np.concatenate([p, a, b]))
    p, a, b = p / s, a / s, b / s
    d = b - a
    dd = float(d @ d)
    lam = 0.0 if dd == 0.0 else float(np.clip(float((p - a) @ d) / dd, 0.0, 1.0))
    r = p - a - lam * d
    return math.hypot(float(r[0]), float(r[1])) * s


@dataclass(frozen=True)
class SupportPolygon:
    """A convex polygon in the ground plane (counter-clockwise vertices).

    Attributes:
        vertices: (k, 2) counter-clockwise vertices [m]; k = 1 (a point) or 2 (a segment)
            when the contacts are degenerate.
    """

    vertices: FloatArray

    @staticmethod
    def from_points(points: Any) -> SupportPolygon:
        """Convex hull of (n, 2) or (n, 3) points (the z coordinate is dropped).

        Any finite coordinates [m]: the hull is scale-invariant (points closer than 1e-12 of
        the points' extent are merged, turns below 1e-12 rad are straight) and its vertices
        are input points. ``area`` is ``inf`` only when it exceeds the float range.
        """
        pts = as_float_array(points, "points")
        if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.shape[0] < 1:
            raise ShapeError("points", (-1, 2), tuple(pts.shape))
        check_finite(pts, "points")
        hull = _convex_hull(np.ascontiguousarray(pts[:, :2]))
        hull.flags.writeable = False
        return SupportPolygon(hull)

    @property
    def is_degenerate(self) -> bool:
        """True for a point or a segment (no interior)."""
        return bool(self.vertices.shape[0] < 3)

    @property
    def area(self) -> float:
        """Area [m^2] (shoelace formula)."""
        if self.is_degenerate:
            return 0.0
        u, _, s, t = _local(self.vertices)
        x, y = u[:, 0], u[:, 1]
        # (in the local frame of unit extent; inf only when the area exceeds the float range)
        return float(0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1))) * t * t * s * s

    @property
    def centroid(self) -> FloatArray:
        """Area centroid [m] (vertex mean when degenerate)."""
        u, w0, s, t = _local(self.vertices)
        if self.is_degenerate:
            return np.asarray((w0 + u.mean(axis=0) * t) * s)
        x, y = u[:, 0], u[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        a = cross.sum() / 2.0
        c = np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6.0 * a)
        return np.asarray((w0 + c * t) * s)

    def halfspaces(self) -> tuple[FloatArray, FloatArray]:
        """``(A, b)`` with the polygon ``{p : A p <= b}`` and unit-norm rows of ``A``.

        Raises:
            InvalidInputError: for a degenerate polygon (no interior, no half-space form).
        """
        if self.is_degenerate:
            raise InvalidInputError(
                "a support polygon with fewer than 3 vertices has no half-space form; "
                "check is_degenerate first"
            )
        u, w0, s, t = _local(self.vertices)
        edge = np.roll(u, -1, axis=0) - u
        normal = np.column_stack([edge[:, 1], -edge[:, 0]])
        normal /= np.hypot(normal[:, 0], normal[:, 1])[:, None]
        # b = n . v = (n . w0 + n . u t) s, in the local frame (no overflow of v's products)
        return normal, (normal @ w0 + np.einsum("ij,ij->i", normal, u) * t) * s

    def margin(self, point: Any) -> float:
        """Signed distance [m] of a ground point to the boundary (positive inside).

        ``point`` is ``(x, y)`` or ``(x, y, z)`` (``z`` ignored).
        """
        p = as_vector(point, None, "point")
        if p.shape[0] not in (2, 3):
            raise InvalidInputError(
                f"point must be a ground point (x, y) or (x, y, z), got {p.shape[0]} entries"
            )
        p = p[:2]
        v = self.vertices
        if v.shape[0] == 1:
            return -_segment_distance(p, v[0], v[0])
        if v.shape[0] == 2:
            return -_segment_distance(p, v[0], v[1])
        A, b = self.halfspaces()
        slack = b - A @ p
        if slack.min() >= 0.0:
            return float(slack.min())
        return -min(_segment_distance(p, v[i], v[(i + 1) % len(v)]) for i in range(len(v)))

    def contains(self, point: Any, margin: float = 0.0) -> bool:
        """True when ``point`` is inside with at least ``margin`` [m] to every edge."""
        return self.margin(point) >= as_scalar(margin, "margin")


def support_polygon(
    robot: Any, q: Any, feet: Sequence[Any], *, ground_height: float | None = None
) -> SupportPolygon:
    """Support polygon of the feet in contact at configuration ``q``.

    Args:
        robot: a :class:`~taskspace.model.Robot`.
        q: configuration.
        feet: the :class:`~taskspace.locomotion.foot.FootGeometry` of every active contact
            (a list, one foot, or the dict of :func:`~taskspace.locomotion.foot.robot_feet`).
        ground_height: when given, refuse vertices farther than 5 mm from this height [m].

    Raises:
        InvalidInputError: no feet, or a vertex away from the ground.
    """
    if isinstance(feet, FootGeometry):
        feet = [feet]
    elif isinstance(feet, Mapping):  # robot_feet(name): the feet by side
        feet = list(feet.values())
    elif isinstance(feet, (str, bytes)) or not isinstance(feet, Iterable):
        raise InvalidInputError(
            f"feet must be a list of FootGeometry (robot_feet(name).values() or "
            f"FootGeometry(frame=..., vertices=...)), got {type(feet).__name__}"
        )
    feet = list(feet)
    if not feet:
        raise InvalidInputError("a support polygon needs at least one foot in contact")
    for i, foot in enumerate(feet):
        if not isinstance(foot, FootGeometry):
            raise InvalidInputError(
                f"feet[{i}] must be a FootGeometry (the foot frame and its contact vertices, "
                f"e.g. robot_feet(name)['left']), got {type(foot).__name__} {foot!r}"
            )
    pts = np.vstack([f.vertices_in_world(robot.frame_placement(q, f.frame)) for f in feet])
    if ground_height is not None:
        ground_height = as_scalar(ground_height, "ground_height [m]")
        off = np.abs(pts[:, 2] - ground_height)
        if off.max() > 5e-3:
            raise InvalidInputError(
                f"contact vertex {int(off.argmax())} is {off.max():.4f} m from the ground "
                f"height {ground_height} m: the foot is not on the ground"
            )
    return SupportPolygon.from_points(pts)


@dataclass(frozen=True)
class StaticStability:
    """Result of :func:`static_stability`.

    Attributes:
        stable: the CoM projection is inside the polygon with the required margin.
        margin: signed distance of the CoM projection to the polygon boundary [m].
        com: the center of mass [m].
        polygon: the support polygon.
    """

    stable: bool
    margin: float
    com: FloatArray
    polygon: SupportPolygon


def static_stability(
    robot: Any, q: Any, feet: Sequence[Any], *, margin: float = 0.0
) -> StaticStability:
    """Static stability test: the ground projection of the CoM inside the support polygon.

    Args:
        robot: a :class:`~taskspace.model.Robot`.
        q: configuration.
        feet: the feet in contact.
        margin: required distance of the CoM projection to every edge [m].
    """
    import pinocchio as pin

    margin = as_scalar(margin, "margin")
    qa = robot.check_configuration(q)
    polygon = support_polygon(robot, qa, feet)
    com = np.asarray(pin.centerOfMass(robot._model, robot._model.createData(), qa)).copy()
    d = polygon.margin(com[:2])
    return StaticStability(stable=d >= margin, margin=d, com=com, polygon=polygon)
