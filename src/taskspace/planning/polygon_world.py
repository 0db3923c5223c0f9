"""2-D worlds of polygonal obstacles: containment, distances, segment intersections.

Used by the Bug algorithms (slides 3:8-3:12), potential fields (3:13-3:17) and the car planner
(3:45-3:60). An obstacle is a simple polygon, optionally with holes (a ring-shaped wall can
enclose a free region). Outer loops are stored counter-clockwise and holes clockwise, so the
obstacle interior is always on the LEFT of every directed edge ``a -> b``.

Geometry used throughout (``cross(u, v) = u_x v_y - u_y v_x``):

* segment ``p + t (q - p)`` meets edge ``a + s (b - a)`` at
  ``t = cross(a - p, b - a) / cross(q - p, b - a)``,
  ``s = cross(a - p, q - p) / cross(q - p, b - a)`` with ``t, s in [0, 1]``;
* a point is inside a polygon if a ray from it crosses the polygon's loops an odd number of
  times (even-odd rule, so holes are handled);
* the distance to an edge is ``|p - (a + clip(s*, 0, 1)(b - a))|`` with
  ``s* = (p - a).(b - a) / |b - a|^2``.

All queries are vectorised over points and edges with numpy.

Thread safety: :class:`Polygon` and :class:`PolygonWorld` are immutable values (frozen dataclasses)
whose queries build new arrays, so they may be shared by threads as long as nobody modifies their
arrays in place.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_matrix, as_vector, check_positive
from taskspace.errors import InvalidInputError, PlanningError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


def _signed_area(v: FloatArray) -> float:
    """Shoelace formula ``A = 1/2 sum_i cross(v_i, v_{i+1})`` (> 0 for counter-clockwise)."""
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _loop(vertices: Any, name: str, ccw: bool) -> FloatArray:
    v = as_matrix(vertices, (None, 2), name)
    if v.shape[0] < 3:
        raise InvalidInputError(f"{name} needs at least 3 vertices, got {v.shape[0]}")
    area = _signed_area(v)
    if abs(area) < 1e-15:
        raise InvalidInputError(f"{name} has zero area")
    if (area > 0) != ccw:
        v = v[::-1].copy()
    return v


@dataclass(frozen=True)
class Polygon:
    """A simple polygon obstacle with optional holes.

    Attributes:
        vertices: outer loop ``(n, 2)`` [m]; stored counter-clockwise.
        holes: inner loops, each ``(m, 2)`` [m]; stored clockwise.
    """

    vertices: FloatArray
    holes: tuple[FloatArray, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "vertices", _loop(self.vertices, "polygon vertices", True))
        object.__setattr__(
            self, "holes", tuple(_loop(h, f"hole {i}", False) for i, h in enumerate(self.holes))
        )

    @property
    def loops(self) -> tuple[FloatArray, ...]:
        """Outer loop followed by the holes."""
        return (self.vertices, *self.holes)

    @staticmethod
    def rectangle(xmin: float, ymin: float, xmax: float, ymax: float) -> Polygon:
        """Axis-aligned rectangle ``[xmin, xmax] x [ymin, ymax]`` [m]."""
        return Polygon(np.array([[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]]))

    @staticmethod
    def regular(center: Any, radius: float, n: int = 16, phase: float = 0.0) -> Polygon:
        """Regular ``n``-gon inscribed in the circle of ``radius`` [m] around ``center``."""
        c = as_vector(center, 2, "center")
        check_positive(radius, "radius")
        a = phase + 2.0 * np.pi * np.arange(n) / n
        return Polygon(c + radius * np.stack([np.cos(a), np.sin(a)], axis=1))

    @staticmethod
    def ring(center: Any, inner: Any, outer: Any) -> Polygon:
        """Rectangular ring: outer rectangle minus inner rectangle.

        Args:
            center: centre of both rectangles [m].
            inner: ``(half_width, half_height)`` of the hole [m].
            outer: ``(half_width, half_height)`` of the outside [m].
        """
        c = as_vector(center, 2, "center")
        hi = as_vector(inner, 2, "inner")
        ho = as_vector(outer, 2, "outer")
        if np.any(hi >= ho):
            raise InvalidInputError(f"ring inner half-sizes {hi} must be smaller than {ho}")

        def rect(h: FloatArray) -> FloatArray:
            return c + np.array([[-h[0], -h[1]], [h[0], -h[1]], [h[0], h[1]], [-h[0], h[1]]])

        return Polygon(rect(ho), (rect(hi),))


@dataclass(frozen=True)
class SegmentHit:
    """First intersection of a segment with the obstacle boundaries.

    Attributes:
        t: segment parameter of the hit in ``[0, 1]``.
        point: hit point [m].
        edge: global edge index.
        polygon: index of the polygon that was hit.
    """

    t: float
    point: FloatArray
    edge: int
    polygon: int


@dataclass(frozen=True)
class PolygonWorld:
    """A set of disjoint polygonal obstacles inside optional rectangular bounds.

    Attributes:
        polygons: the obstacles (must not overlap each other).
        bounds: ``(xmin, ymin, xmax, ymax)`` of the workspace [m], or ``None`` for unbounded.
    """

    polygons: tuple[Polygon, ...]
    bounds: tuple[float, float, float, float] | None = None
    edges: FloatArray = field(init=False, repr=False)
    edge_polygon: IntArray = field(init=False, repr=False)
    edge_loop: IntArray = field(init=False, repr=False)
    loop_vertices: tuple[FloatArray, ...] = field(init=False, repr=False)
    loop_first_edge: IntArray = field(init=False, repr=False)
    loop_polygon: IntArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        polys = tuple(self.polygons)
        for i, p in enumerate(polys):
            if not isinstance(p, Polygon):
                raise InvalidInputError(f"polygons[{i}] must be a Polygon, got {type(p).__name__}")
        object.__setattr__(self, "polygons", polys)
        if self.bounds is not None:
            b = as_vector(self.bounds, 4, "bounds")
            if not (b[0] < b[2] and b[1] < b[3]):
                raise InvalidInputError(f"bounds must be (xmin, ymin, xmax, ymax), got {b}")
            object.__setattr__(self, "bounds", tuple(float(v) for v in b))
        edges: list[FloatArray] = []
        loops: list[FloatArray] = []
        epoly: list[int] = []
        eloop: list[int] = []
        first: list[int] = []
        lpoly: list[int] = []
        n_edges = 0
        for pi, poly in enumerate(polys):
            for v in poly.loops:
                li = len(loops)
                loops.append(v)
                first.append(n_edges)
                lpoly.append(pi)
                e = np.stack([v, np.roll(v, -1, axis=0)], axis=1)
                edges.append(e)
                epoly += [pi] * len(v)
                eloop += [li] * len(v)
                n_edges += len(v)
        object.__setattr__(self, "edges", np.concatenate(edges) if edges else np.zeros((0, 2, 2)))
        object.__setattr__(self, "edge_polygon", np.asarray(epoly, dtype=np.int64))
        object.__setattr__(self, "edge_loop", np.asarray(eloop, dtype=np.int64))
        object.__setattr__(self, "loop_vertices", tuple(loops))
        object.__setattr__(self, "loop_first_edge", np.asarray(first, dtype=np.int64))
        object.__setattr__(self, "loop_polygon", np.asarray(lpoly, dtype=np.int64))
        overlap = self._overlap()
        if overlap is not None:
            i, j, how = overlap
            raise InvalidInputError(
                f"polygons[{i}] and polygons[{j}] overlap ({how}): the obstacles of a "
                "PolygonWorld must be disjoint (boundary following, the Bug algorithms, needs "
                "one boundary per obstacle); merge them into one polygon"
            )

    def _overlap(self) -> tuple[int, int, str] | None:
        """Two polygons whose boundaries cross or one inside the other, else ``None``.

        Boundaries cross when two edges of different polygons intersect at a point interior
        to both (strict orientation signs: touching at a vertex or along a line is allowed);
        containment is tested on one vertex of each polygon (even-odd rule per polygon, so a
        polygon inside another's hole is disjoint from it).
        """
        n_poly = len(self.polygons)
        if n_poly < 2:
            return None
        e, ep = self.edges, self.edge_polygon
        a, b = e[:, None, 0, :], e[:, None, 1, :]
        c, d = e[None, :, 0, :], e[None, :, 1, :]

        def orient(p: FloatArray, q: FloatArray, r: FloatArray) -> FloatArray:
            return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
                r[..., 0] - p[..., 0]
            )

        cross = (orient(a, b, c) * orient(a, b, d) < 0) & (orient(c, d, a) * orient(c, d, b) < 0)
        cross &= ep[:, None] != ep[None, :]
        if cross.any():
            k, m = np.argwhere(cross)[0]
            return int(min(ep[k], ep[m])), int(max(ep[k], ep[m])), "their boundaries cross"
        firsts = np.array([p.loops[0][0] for p in self.polygons])
        inside = self._inside_each(firsts)  # (polygon's vertex, polygon)
        np.fill_diagonal(inside, False)
        if inside.any():
            i, j = (int(k) for k in np.argwhere(inside)[0])
            return min(i, j), max(i, j), f"polygons[{i}] lies inside polygons[{j}]"
        return None

    # ------------------------------------------------------------------ queries
    def polygon_containing(self, points: Any) -> IntArray:
        """Index of the polygon containing each point, ``-1`` for free points.

        Even-odd ray casting to ``+x`` per polygon (points exactly on an edge count as
        inside only by the half-open convention ``y_a <= y < y_b``).

        Args:
            points: ``(2,)`` or ``(N, 2)`` [m].

        Returns:
            ``(N,)`` int array.
        """
        p = np.atleast_2d(np.asarray(points, dtype=float))
        out = np.full(p.shape[0], -1, dtype=np.int64)
        if self.edges.shape[0] == 0:
            return out
        inside = self._inside_each(p)
        hit = inside.any(axis=1)
        out[hit] = np.argmax(inside[hit], axis=1)  # the first polygon containing the point
        return out

    def _inside_each(self, p: FloatArray) -> BoolArray:
        """``(N, n_polygons)`` booleans: point ``i`` inside polygon ``j``.

        Even-odd ray casting to ``+x`` over the polygon's loops, holes included; a point on an
        edge counts by the half-open convention ``y_a <= y < y_b``.
        """
        a = self.edges[None, :, 0, :]
        b = self.edges[None, :, 1, :]
        px = p[:, None, 0]
        py = p[:, None, 1]
        straddle = (a[..., 1] <= py) != (b[..., 1] <= py)
        dy = b[..., 1] - a[..., 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            xcross = a[..., 0] + (py - a[..., 1]) * (b[..., 0] - a[..., 0]) / dy
        crosses = straddle & (xcross > px)
        inside = np.zeros((p.shape[0], len(self.polygons)), dtype=bool)
        for pi in range(len(self.polygons)):
            inside[:, pi] = np.sum(crosses[:, self.edge_polygon == pi], axis=1) % 2 == 1
        return inside

    def contains(self, points: Any) -> BoolArray:
        """``True`` where a point is inside some obstacle, shape ``(N,)``."""
        return self.polygon_containing(points) >= 0

    def in_bounds(self, points: Any) -> BoolArray:
        """``True`` where a point lies inside the workspace bounds (always without bounds)."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        if self.bounds is None:
            return np.ones(p.shape[0], dtype=bool)
        x0, y0, x1, y1 = self.bounds
        return (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)

    def is_free(self, points: Any) -> BoolArray:
        """In bounds and outside every obstacle, shape ``(N,)``."""
        return self.in_bounds(points) & ~self.contains(points)

    def closest_points(self, points: Any) -> tuple[FloatArray, FloatArray]:
        """Distance from each point to each polygon's boundary and the closest points.

        Args:
            points: ``(2,)`` or ``(N, 2)`` [m].

        Returns:
            ``(dist, closest)``: distances ``(N, P)`` [m] (unsigned) and closest boundary
            points ``(N, P, 2)`` for the ``P`` polygons.
        """
        p = np.atleast_2d(np.asarray(points, dtype=float))
        n, npoly = p.shape[0], len(self.polygons)
        if npoly == 0:
            return np.full((n, 0), np.inf), np.zeros((n, 0, 2))
        a = self.edges[:, 0, :]
        d = self.edges[:, 1, :] - a
        dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
        s = np.clip(np.einsum("nij,ij->ni", p[:, None, :] - a[None], d) / dd, 0.0, 1.0)
        c = a[None] + s[..., None] * d[None]
        dist = np.linalg.norm(p[:, None, :] - c, axis=-1)
        out_d = np.empty((n, npoly))
        out_c = np.empty((n, npoly, 2))
        rows = np.arange(n)
        for pi in range(npoly):
            idx = np.flatnonzero(self.edge_polygon == pi)
            k = idx[np.argmin(dist[:, idx], axis=1)]
            out_d[:, pi] = dist[rows, k]
            out_c[:, pi] = c[rows, k]
        return out_d, out_c

    def signed_distance(self, points: Any) -> FloatArray:
        """Distance to the nearest obstacle boundary, negative inside an obstacle [m]."""
        dist, _ = self.closest_points(points)
        if dist.shape[1] == 0:
            return np.full(dist.shape[0], np.inf)
        d = dist.min(axis=1)
        return np.where(self.contains(points), -d, d)

    def segment_hits(self, p: Any, q: Any) -> list[SegmentHit]:
        """All intersections of segment ``p -> q`` with obstacle edges, sorted by ``t``.

        Parallel (collinear) edges are ignored.

        Args:
            p: segment start [m].
            q: segment end [m].
        """
        p = np.asarray(p, dtype=float)
        q = np.asarray(q, dtype=float)
        if self.edges.shape[0] == 0:
            return []
        r = q - p
        a = self.edges[:, 0, :]
        e = self.edges[:, 1, :] - a
        ap = a - p
        den = r[0] * e[:, 1] - r[1] * e[:, 0]
        ok = np.abs(den) > 1e-15
        den_safe = np.where(ok, den, 1.0)
        t = (ap[:, 0] * e[:, 1] - ap[:, 1] * e[:, 0]) / den_safe
        s = (ap[:, 0] * r[1] - ap[:, 1] * r[0]) / den_safe
        tol = 1e-12
        hit = ok & (t >= -tol) & (t <= 1 + tol) & (s >= -tol) & (s <= 1 + tol)
        idx = np.flatnonzero(hit)
        idx = idx[np.argsort(t[idx], kind="stable")]
        return [
            SegmentHit(
                float(np.clip(t[i], 0.0, 1.0)),
                p + float(np.clip(t[i], 0.0, 1.0)) * r,
                int(i),
                int(self.edge_polygon[i]),
            )
            for i in idx
        ]

    def segment_free(self, p: Any, q: Any) -> bool:
        """Whether segment ``p -> q`` stays in bounds and touches no obstacle."""
        pts = np.stack([np.asarray(p, float), np.asarray(q, float)])
        if not np.all(self.is_free(pts)):
            return False
        return len(self.segment_hits(p, q)) == 0

    def check_free_point(self, point: Any, name: str) -> FloatArray:
        """Validate a point: finite, in bounds, outside obstacles.

        Raises:
            PlanningError: if the point is out of bounds or inside an obstacle.
        """
        x = as_vector(point, 2, name)
        if not self.in_bounds(x)[0]:
            raise PlanningError(
                f"{name} ({x[0]:g}, {x[1]:g}) is outside the world bounds {self.bounds}"
            )
        k = int(self.polygon_containing(x)[0])
        if k >= 0:
            raise PlanningError(f"{name} ({x[0]:g}, {x[1]:g}) is inside obstacle {k}")
        return x


def make_world(
    polygons: Sequence[Polygon | Any], bounds: tuple[float, float, float, float] | None = None
) -> PolygonWorld:
    """Build a :class:`PolygonWorld` from polygons or raw vertex arrays."""
    polys = tuple(p if isinstance(p, Polygon) else Polygon(np.asarray(p, float)) for p in polygons)
    return PolygonWorld(polys, bounds)
