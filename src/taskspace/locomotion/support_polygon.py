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

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, as_vector, check_finite
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.locomotion.foot import FootGeometry


def _convex_hull(points: FloatArray) -> FloatArray:
    """Counter-clockwise convex hull of 2-D points (Andrew's monotone chain), no collinear."""
    pts = np.unique(np.round(points, 12), axis=0)
    if pts.shape[0] <= 2:
        return pts
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    pts = pts[order]

    def half(seq: FloatArray) -> list[FloatArray]:
        chain: list[FloatArray] = []
        for p in seq:
            while len(chain) >= 2:
                o, a = chain[-2], chain[-1]
                cross = (a[0] - o[0]) * (p[1] - o[1]) - (a[1] - o[1]) * (p[0] - o[0])
                if cross > 1e-14:
                    break
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(pts[::-1])
    hull = np.array(lower[:-1] + upper[:-1])
    return hull


def _segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> float:
    d = b - a
    s = float(np.clip(float((p - a) @ d) / max(float(d @ d), 1e-300), 0.0, 1.0))
    return float(np.linalg.norm(p - a - s * d))


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
        """Convex hull of (n, 2) or (n, 3) points (the z coordinate is dropped)."""
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
        x, y = self.vertices[:, 0], self.vertices[:, 1]
        return float(0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1)))

    @property
    def centroid(self) -> FloatArray:
        """Area centroid [m] (vertex mean when degenerate)."""
        if self.is_degenerate:
            return np.asarray(self.vertices.mean(axis=0))
        x, y = self.vertices[:, 0], self.vertices[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        a = cross.sum() / 2.0
        return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6.0 * a)

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
        v = self.vertices
        edge = np.roll(v, -1, axis=0) - v
        normal = np.column_stack([edge[:, 1], -edge[:, 0]])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        return normal, np.einsum("ij,ij->i", normal, v)

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
            return -float(np.linalg.norm(p - v[0]))
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
