"""Conservative sphere approximation of a robot's collision geometry (VAMP-style checking).

Vectorized planners (VAMP, Thomason, Kingston and Kavraki, ICRA 2024) check a batch of
configurations at once against spheres attached to the links instead of the link meshes.
The approximation must be *conservative*: wherever the robot's geometry is, a sphere must be,
so that "free" for the spheres implies "free" for the meshes. This module builds such spheres
from the collision geometry of a ``pin.GeometryModel``, one set per geometry object, expressed
in the frame of the geometry's parent joint (where forward kinematics puts them).

Method, for one geometry object (a mesh, a convex hull, or a box / cylinder / capsule /
sphere primitive):

1. **Surface samples.** Every triangle ``(a, b, c)`` of the surface (meshes and convex hulls
   as coal stores them, primitives triangulated around the shape) is cut into ``m^2`` equal
   sub-triangles, ``m = ceil(longest edge / h)``, and its grid points
   ``a + (i (b - a) + j (c - a)) / m`` (``i + j <= m``) are kept: the mesh vertices and
   points at most ``h`` apart along every sub-triangle edge. Any point of a triangle whose
   longest edge is ``l`` lies within ``l / sqrt(3)`` of one of its corners (the farthest point
   from the corners is the circumcentre of an acute triangle, radius ``l / (2 sin C)`` with
   ``C >= 60 deg`` the largest angle, or the middle of the longest edge), so every surface
   point lies within ``rho = h / sqrt(3)`` of a sample.
2. **Interior samples.** The points of a cubic grid of spacing ``g`` (default 1 cm) inside
   the convex hull of the surface samples are added, so that a tube gets spheres through its
   middle rather than a ring of spheres around a hollow core. The hull contains the
   geometry's volume (for a non-convex mesh, more than it).
3. **Spheres** (:func:`fit_spheres`), chosen to bulge out of the hull as little as possible
   (the bulge is what makes the sphere checkers more conservative than the exact ones).
   Candidate centres are the points ``c`` of a grid inside the hull, each with its depth
   ``d(c)`` (distance to the nearest facet plane); for a bulge ``delta`` the candidate ball
   has radius ``d(c) + delta`` and reaches at most ``delta`` beyond any facet plane. The
   samples are covered greedily by such balls and ``delta`` is bisected to the smallest
   that needs at most ``spheres_per_geometry`` of them. Each sample then goes to the chosen
   ball it lies deepest in, and each sphere has that centre ``c`` and radius
   ``max_i |p_i - c| + rho`` over its samples ``p_i``. (A geometry without volume gets
   recursive median splits of its samples instead: slab-shaped clusters, whose spheres
   reach far beyond the flat sides of a link.)
4. **Guarantee.** Every sample is inside its cluster's sphere with a margin ``rho``, so every
   surface point ``x`` (within ``rho`` of some sample ``p``) satisfies
   ``|x - c| <= |p - c| + rho <= r``: the union of the spheres contains the whole surface, in
   particular every mesh vertex (proved). Swept-sphere radii of coal shapes are added to the
   radii.
5. **Volume certificate** (:func:`certify_cover`). The whole convex hull ``H`` of the
   surface triangles (the geometry itself for a convex hull, a box or the prism; more than
   a non-convex mesh) is proved to lie inside the union of the spheres shrunk by
   ``certified_margin`` (default 10 um): ``H`` is the union of the tetrahedra joining its
   vertex centroid to its facets; a simplex lies inside a ball exactly when its vertices
   do (a ball is convex), so a simplex whose vertices all lie in one shrunk ball is covered;
   any other is cut in two at the middle of its longest edge and both halves are tried
   again. A piece smaller than 1 mm that no shrunk ball contains enlarges the ball that
   needs the least growth to contain it (none on the Panda: its 16 moving geometries are
   proved with 100-5,000 simplices each, about 0.2 s in all). A sphere primitive gets the
   margin added to its radius. Consequence, used by the compiled checkers: when no sphere
   of a geometry touches another object (or another geometry's spheres), the geometry's
   hull is at least ``certified_margin`` away from it, so the exact (mesh or convex)
   narrow phase also answers "free": the spheres are a proven-conservative certificate of
   the exact check (the rounding of the kinematics, about 1e-15 m, and coal's GJK
   tolerance, 1e-6 m, lie far inside the margin). The tests check the proof on dense random
   points of the hulls' volumes and the checkers against Pinocchio near contact.

The spheres are larger than the geometry by ``rho`` plus the spherical bulge of each
cluster: :attr:`SphereModel.radii` minus the farthest sample is exactly ``rho``
(``h = 4 mm``: 2.3 mm). More spheres fit tighter. Primitives: a sphere is kept exactly; a
cylinder or capsule is replaced by the circumscribed 32-gon prism (and the end spheres of a
capsule), a box by its 12 triangles; other coal shapes (cones, ellipsoids, planes, height
fields, octrees) are refused.

:func:`obstacle_signed_distances` and :func:`spheres_hit_obstacles` test the spheres against
the world's boxes, spheres, cylinders and capsules for a batch of configurations, in NumPy
(forward kinematics one configuration at a time through Pinocchio), tested to never call
"free" a configuration whose meshes touch an obstacle. Robot self-collision is not checked
here. The compiled sphere checkers (``taskspace/_native/planning_kernel.cpp``, self pairs
included; :meth:`taskspace.planning.CollisionChecker.sphere_kernel` and
``RRTConnectOptions.checker``) use these spheres.
"""

from __future__ import annotations

import hashlib
import heapq
import logging
import math
import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import as_matrix, check_positive
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.model.world import Obstacle

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

logger = logging.getLogger(__name__)

SUPPORTED_SHAPES = ("mesh (BVHModel)", "Convex", "Box", "Cylinder", "Capsule", "Sphere")
"""Geometry types :func:`sphere_model` approximates."""

_PRISM_SIDES = 32


@dataclass(frozen=True, kw_only=True)
class SphereModelOptions:
    """Settings of :func:`sphere_model`.

    Attributes:
        spheres_per_geometry: number of spheres per geometry object (at most; fewer when a
            geometry has fewer surface samples), >= 1.
        surface_spacing: ``h`` [m], the largest sub-triangle edge of the surface samples; the
            spheres are inflated by ``h / sqrt(3)``.
        interior_spacing: ``g`` [m], spacing of the interior grid samples.
        certified_margin: ``epsilon`` [m] of the volume certificate (:func:`certify_cover`):
            every point of each geometry's convex hull is proved to lie at least this far
            inside the union of its spheres (balls grown where the proof needs it); > 0.
    """

    spheres_per_geometry: int = 12
    surface_spacing: float = 0.004
    interior_spacing: float = 0.01
    certified_margin: float = 1e-5


@dataclass(frozen=True)
class SphereModel:
    """Spheres covering the collision geometry, attached to the joints.

    Sphere ``k`` has centre ``centers[k]`` in the frame of joint ``joints[k]`` and radius
    ``radii[k]``; it belongs to geometry object ``geometries[k]`` of the geometry model (name
    ``names[k]``). In the world: ``oMi[joints[k]] * centers[k]``.

    Attributes:
        centers: sphere centres in their joint frames [m], shape ``(M, 3)``.
        radii: sphere radii [m], shape ``(M,)``.
        joints: parent joint index of every sphere, shape ``(M,)``.
        geometries: geometry object index of every sphere, shape ``(M,)``.
        names: geometry object name of every sphere.
        covering_radius: ``rho = h / sqrt(3)`` [m], the inflation of every radius.
        certified_margin: ``epsilon`` [m]: every point of each geometry's convex hull lies
            at least this far inside the union of that geometry's spheres (proved by
            :func:`certify_cover`); 0 when not proved (a model built by hand).
    """

    centers: FloatArray
    radii: FloatArray
    joints: IntArray
    geometries: IntArray
    names: tuple[str, ...]
    covering_radius: float
    certified_margin: float = 0.0

    @property
    def count(self) -> int:
        """Number of spheres ``M``."""
        return int(self.radii.shape[0])

    def world_centers(self, data: pin.Data) -> FloatArray:
        """Sphere centres in the world frame [m], ``(M, 3)``, from ``data.oMi``.

        Args:
            data: Pinocchio data after ``pin.forwardKinematics`` at the configuration.
        """
        out = np.empty_like(self.centers)
        for j in np.unique(self.joints):
            sel = self.joints == j
            m = data.oMi[int(j)]
            out[sel] = self.centers[sel] @ m.rotation.T + m.translation
        return out

    def of_geometry(self, name: str) -> tuple[FloatArray, FloatArray]:
        """Centres (joint frame) and radii of the spheres of geometry object ``name``.

        Raises:
            UnknownNameError: no sphere covers a geometry of that name.
        """
        sel = np.array([n == name for n in self.names], dtype=bool)
        if not sel.any():
            raise UnknownNameError("geometry", name, set(self.names))
        return self.centers[sel], self.radii[sel]


def _triangle_samples(tris: FloatArray, spacing: float) -> FloatArray:
    """Grid points of every triangle ``tris (T, 3, 3)``, sub-triangle edges <= ``spacing``."""
    edges = np.stack(
        [
            np.linalg.norm(tris[:, 1] - tris[:, 0], axis=1),
            np.linalg.norm(tris[:, 2] - tris[:, 1], axis=1),
            np.linalg.norm(tris[:, 0] - tris[:, 2], axis=1),
        ],
        axis=1,
    )
    m_all = np.maximum(np.ceil(edges.max(axis=1) / spacing - 1e-12), 1).astype(int)
    out = [tris.reshape(-1, 3)]
    for m in np.unique(m_all):
        if m == 1:
            continue
        sel = tris[m_all == m]
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        keep = (i + j) <= m
        wi, wj = i[keep] / m, j[keep] / m
        a, b, c = sel[:, 0], sel[:, 1], sel[:, 2]
        pts = (
            a[:, None, :]
            + wi[None, :, None] * (b - a)[:, None, :]
            + wj[None, :, None] * (c - a)[:, None, :]
        )
        out.append(pts.reshape(-1, 3))
    return np.concatenate(out)


def _prism(radius: float, half_length: float) -> FloatArray:
    """Triangles of the prism circumscribed about a z-axis cylinder (contains it)."""
    rc = radius / math.cos(math.pi / _PRISM_SIDES)
    ang = 2 * math.pi * np.arange(_PRISM_SIDES) / _PRISM_SIDES
    ring = np.stack([rc * np.cos(ang), rc * np.sin(ang), np.zeros_like(ang)], axis=1)
    ct, cb = np.array([0.0, 0.0, half_length]), np.array([0.0, 0.0, -half_length])
    top, bot = ring + ct, ring + cb
    tris = []
    for k in range(_PRISM_SIDES):
        n = (k + 1) % _PRISM_SIDES
        tris += [(bot[k], bot[n], top[n]), (bot[k], top[n], top[k]), (ct, top[k], top[n])]
        tris += [(cb, bot[n], bot[k])]
    return np.asarray(tris, dtype=float)


def _box(half: FloatArray) -> FloatArray:
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    v = corners * half
    faces = [
        (0, 1, 3, 2),
        (4, 6, 7, 5),
        (0, 4, 5, 1),
        (2, 3, 7, 6),
        (0, 2, 6, 4),
        (1, 5, 7, 3),
    ]
    return np.asarray(
        [tri for a, b, c, d in faces for tri in ((v[a], v[b], v[c]), (v[a], v[c], v[d]))]
    )


def surface_triangles(geometry: coal.CollisionGeometry, name: str = "geometry") -> FloatArray:
    """Triangles ``(T, 3, 3)`` covering the surface of a coal geometry, in its own frame [m].

    Meshes and convex hulls: their triangles. Box: its 12 triangles. Cylinder and capsule:
    the circumscribed 32-gon prism (it contains the cylinder; a capsule's end spheres are
    added separately by :func:`sphere_model`). Sphere: none (kept as a sphere).

    Raises:
        InvalidInputError: another shape type (the message lists the supported ones).
    """
    if isinstance(geometry, coal.BVHModelBase):
        v = np.asarray(geometry.vertices(), dtype=float)
        idx = [geometry.tri_indices(i) for i in range(geometry.num_tris)]
        return v[np.array([[t[0], t[1], t[2]] for t in idx], dtype=int)].reshape(-1, 3, 3)
    if isinstance(geometry, coal.ConvexBase):
        v = np.asarray(geometry.points(), dtype=float)
        idx = [geometry.polygons(i) for i in range(geometry.num_polygons)]
        tris = []
        for p in idx:  # fan triangulation of each polygon
            k = [p[i] for i in range(p.size())]
            tris += [(k[0], k[i], k[i + 1]) for i in range(1, len(k) - 1)]
        return v[np.array(tris, dtype=int)].reshape(-1, 3, 3)
    if isinstance(geometry, coal.Box):
        return _box(np.asarray(geometry.halfSide, dtype=float))
    if isinstance(geometry, (coal.Cylinder, coal.Capsule)):
        return _prism(float(geometry.radius), float(geometry.halfLength))
    if isinstance(geometry, coal.Sphere):
        return np.zeros((0, 3, 3))
    raise InvalidInputError(
        f"geometry '{name}' is a {type(geometry).__name__}; sphere models support: "
        f"{', '.join(SUPPORTED_SHAPES)}"
    )


def interior_samples(points: FloatArray, spacing: float) -> FloatArray:
    """Points of a cubic grid of ``spacing`` [m] inside the convex hull of ``points (n, 3)``.

    Empty when the points span no volume (a flat or degenerate geometry).
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return np.zeros((0, 3))
    lo, hi = points.min(axis=0), points.max(axis=0)
    axes = [np.arange(lo[k] + 0.5 * spacing, hi[k], spacing) for k in range(3)]
    if any(a.size == 0 for a in axes):
        return np.zeros((0, 3))
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    eq = hull.equations  # n . x + d <= 0 inside
    # in chunks of about 2^22 plane tests (a 1 cm grid of a 40 cm torso against 3,000
    # facets would be a gigabyte at once)
    rows = max(1, (1 << 22) // max(1, eq.shape[0]))
    inside = np.concatenate(
        [
            np.all(grid[k : k + rows] @ eq[:, :3].T + eq[:, 3] <= 0.0, axis=1)
            for k in range(0, grid.shape[0], rows)
        ]
    )
    return np.asarray(grid[inside], dtype=float)


_MAX_CANDIDATES = 1500  # ball centres fit_spheres chooses from (grid spacing grows beyond)
_MAX_TARGETS = 5000  # thinned points fit_spheres covers while choosing (all are covered after)
_BISECTIONS = 12  # halvings of fit_spheres' bulge bracket (the bounding-box diagonal / 4096)


def _thinned(points: FloatArray, spacing: float) -> FloatArray:
    """One point (the first) of ``points`` per cell of a cubic grid of ``spacing`` [m]."""
    cells = np.floor((points - points.min(axis=0)) / spacing).astype(np.int64)
    size = cells.max(axis=0) + 1
    key = cells[:, 0] + size[0] * (cells[:, 1] + size[1] * cells[:, 2])  # one int per cell
    _, first = np.unique(key, return_index=True)
    return points[np.sort(first)]


def _distances(a: FloatArray, b: FloatArray) -> FloatArray:
    """The ``(len(a), len(b))`` distances, by ``|a|^2 + |b|^2 - 2 a.b``.

    No ``(n, m, 3)`` array; rounded at the scale of the squares: for choosing, not for radii.
    """
    square = (
        np.einsum("ik,ik->i", a, a)[:, None] + np.einsum("jk,jk->j", b, b)[None, :] - 2.0 * a @ b.T
    )
    return np.asarray(np.sqrt(np.maximum(square, 0.0)))


def fit_spheres(
    points: FloatArray, count: int, margin: float, hull_points: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """At most ``count`` spheres containing every point with a margin, bulging little.

    The balls are chosen to stick out of the convex hull ``H`` of ``hull_points`` (default
    ``points``) as little as possible, since what they add to the geometry is what makes the
    sphere checkers more conservative than the exact ones. Candidates: the points ``c`` of a
    cubic grid inside ``H`` (spacing: the smallest extent of the points / 8, coarser when
    that gives more than 1,500), each with its depth ``d(c)``, the distance to the nearest
    facet plane of ``H``. For a bulge ``delta``, candidate ``c`` is the ball of radius
    ``d(c) + delta``: it reaches at most ``delta`` beyond any facet plane. The points,
    thinned to one per grid cell, are covered greedily (each time the candidate covering
    the most uncovered ones), and ``delta`` is bisected (12 halvings of the bounding-box
    diagonal) to the smallest for which ``count`` balls suffice. Every point is then given
    to the chosen ball it lies deepest in, and each ball gets radius ``max |p - c| +
    margin`` over its points: every point lies inside a ball with the margin. A geometry
    that spans no volume, or has no grid point inside, gets recursive median splits
    (:func:`_split_spheres`).

    Args:
        points: ``(n, 3)`` points [m] to contain (surface and interior samples), n >= 1.
        count: largest number of spheres, >= 1.
        margin: added to every radius [m], >= 0.
        hull_points: points whose convex hull bounds the bulge (default ``points``).

    Returns:
        ``(centers (k, 3), radii (k,))``, ``1 <= k <= count``.
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points if hull_points is None else hull_points)
    except (QhullError, ValueError):
        return _split_spheres(points, count, margin)
    eq = hull.equations  # n . x + b <= 0 inside, |n| = 1
    lo, hi = points.min(axis=0), points.max(axis=0)
    ext = hi - lo
    spacing = max(float(ext.min()) / 8.0, 1e-3)
    while True:
        axes = [np.arange(lo[k] + 0.5 * spacing, hi[k], spacing) for k in range(3)]
        if np.prod([a.size for a in axes]) <= 4 * _MAX_CANDIDATES:
            grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            depth = -(grid @ eq[:, :3].T + eq[:, 3]).max(axis=1)
            if np.count_nonzero(depth > 0.0) <= _MAX_CANDIDATES:
                break
        spacing *= 1.25
    candidates, depth = grid[depth > 0.0], depth[depth > 0.0]
    if candidates.shape[0] == 0:
        return _split_spheres(points, count, margin)
    step = spacing
    targets = _thinned(points, step)
    while targets.shape[0] > _MAX_TARGETS:  # (a coarser grid on the thinned points)
        step *= 1.25
        targets = _thinned(targets, step)
    reach = _distances(candidates, targets) + margin  # (C, T)

    def cover(delta: float) -> list[int] | None:
        covers = (reach <= (depth + delta)[:, None]).astype(np.float32)
        open_ = np.ones(targets.shape[0], dtype=np.float32)
        chosen: list[int] = []
        while open_.any():
            gain = covers @ open_  # uncovered targets each candidate covers (exact counts)
            best = int(gain.argmax())
            if gain[best] == 0.0 or len(chosen) == count:
                return None
            chosen.append(best)
            open_[covers[best] > 0.0] = 0.0
        return chosen

    low, high = 0.0, float(np.linalg.norm(ext)) + margin
    chosen = cover(high)  # one ball covers everything
    if chosen is None:
        return _split_spheres(points, count, margin)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (low + high)
        found = cover(mid)
        if found is None:
            low = mid
        else:
            high, chosen = mid, found
    centers, ball = candidates[chosen], depth[chosen] + high
    radii = np.zeros(len(chosen))
    used = np.zeros(len(chosen), dtype=bool)
    for k in range(0, points.shape[0], 1 << 16):  # (chunks: millions of samples on a big body)
        p = points[k : k + (1 << 16)]
        owner = np.argmin(_distances(p, centers) - ball, axis=1)
        # the radii from the exact distances to the owners (the choice above may round)
        offset = p - centers[owner]
        np.maximum.at(radii, owner, np.sqrt(np.einsum("nk,nk->n", offset, offset)))
        used[owner] = True
    return centers[used], radii[used] + margin


def _split_spheres(points: FloatArray, count: int, margin: float) -> tuple[FloatArray, FloatArray]:
    """Spheres containing every point with a margin, by recursive median splits.

    The cluster with the largest sphere is cut at the median of its longest bounding-box axis
    until there are ``count`` clusters; each sphere is centred on its cluster's bounding box
    with radius ``max |p - c| + margin``. (:func:`fit_spheres` for geometries without volume.)

    Args:
        points: ``(n, 3)`` points [m], n >= 1.
        count: number of spheres (at most ``n``), >= 1.
        margin: added to every radius [m], >= 0.

    Returns:
        ``(centers (k, 3), radii (k,))`` with ``k = min(count, n)``.
    """

    def sphere(p: FloatArray) -> tuple[FloatArray, float]:
        c = 0.5 * (p.min(axis=0) + p.max(axis=0))
        e = p - c
        return c, float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))

    heap: list[tuple[float, int, FloatArray, FloatArray]] = []
    c0, r0 = sphere(points)
    heap.append((-r0, 0, c0, points))
    serial = 1
    while len(heap) < count:
        neg_r, _, _, p = heap[0]
        if p.shape[0] < 2 or neg_r == 0.0:
            break
        heapq.heappop(heap)
        axis = int(np.argmax(p.max(axis=0) - p.min(axis=0)))
        half = p.shape[0] // 2
        order = np.argpartition(p[:, axis], half)
        for part in (p[order[:half]], p[order[half:]]):
            cp, rp = sphere(part)
            heapq.heappush(heap, (-rp, serial, cp, part))
            serial += 1
    centers = np.array([h[2] for h in heap])
    radii = np.array([-h[0] + margin for h in heap])
    return centers, radii


_LEAF_SIZE = 1e-3  # [m] longest edge of a simplex that certify_cover no longer cuts
_MAX_PIECES = 20_000  # pieces certify_cover keeps at once (beyond: balls grow for them all)


def _simplex_pieces(simplices: FloatArray) -> FloatArray:
    """Each simplex ``(N, k, 3)`` cut in two at the middle of its longest edge: ``(2N, k, 3)``."""
    k = simplices.shape[1]
    pairs = np.array([(i, j) for i in range(k) for j in range(i + 1, k)])
    edges = simplices[:, pairs[:, 0]] - simplices[:, pairs[:, 1]]
    longest = np.einsum("npi,npi->np", edges, edges).argmax(axis=1)
    a, b = pairs[longest, 0], pairs[longest, 1]
    n = np.arange(simplices.shape[0])
    mid = 0.5 * (simplices[n, a] + simplices[n, b])
    first, second = simplices.copy(), simplices.copy()
    first[n, a] = mid
    second[n, b] = mid
    return np.concatenate([first, second])


def _longest_edges(simplices: FloatArray) -> FloatArray:
    """Longest edge length of each simplex ``(N, k, 3)``: ``(N,)``."""
    k = simplices.shape[1]
    pairs = np.array([(i, j) for i in range(k) for j in range(i + 1, k)])
    edges = simplices[:, pairs[:, 0]] - simplices[:, pairs[:, 1]]
    return np.asarray(np.sqrt(np.einsum("npi,npi->np", edges, edges).max(axis=1)))


def _initial_simplices(triangles: FloatArray) -> FloatArray:
    """Tetrahedra from the vertex centroid of the triangles' convex hull to its facets.

    Their union is the hull. Corners that span no volume give the triangles themselves
    (a flat geometry: its surface is all there is to cover).
    """
    from scipy.spatial import ConvexHull, QhullError

    points = triangles.reshape(-1, 3)
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return triangles
    facets = points[hull.simplices]
    centroid = points[hull.vertices].mean(axis=0)
    apex = np.broadcast_to(centroid, (facets.shape[0], 1, 3))
    return np.concatenate([apex, facets], axis=1)


def certify_cover(
    triangles: FloatArray, centers: FloatArray, radii: FloatArray, margin: float
) -> tuple[FloatArray, int]:
    """Radii whose balls, shrunk by ``margin``, provably cover the triangles' convex hull.

    The hull of the triangle corners is cut into the tetrahedra joining the centroid of its
    vertices to its facets (their union is the hull). A simplex lies inside a ball exactly
    when its vertices do (a ball is convex): a simplex whose vertices all lie inside one ball
    of radius ``r - margin`` is covered; any other is cut in two at the middle of its longest
    edge (the halves' union is the simplex) and both halves are tried again. A piece whose
    longest edge is at most 1 mm and that no ball contains grows the ball that needs the
    least growth to contain it with the margin (so do all the pieces left when more than
    20,000 would be cut: a large hole). Every piece thus ends inside one ball: the
    union of the balls of the returned radii, shrunk by ``margin``, contains the hull.

    Args:
        triangles: ``(T, 3, 3)`` surface triangles [m] (e.g. :func:`surface_triangles`).
        centers: ``(S, 3)`` ball centres [m] in the triangles' frame, S >= 1.
        radii: ``(S,)`` ball radii [m].
        margin: ``epsilon`` [m], >= 0.

    Returns:
        ``(radii, grown)``: the radii (unchanged where the proof needed no growth) and the
        number of pieces that made a ball grow.
    """
    out = np.array(radii, dtype=float)
    if triangles.shape[0] == 0:
        return out, 0
    simplices = _initial_simplices(triangles)
    leaves: list[FloatArray] = []
    while simplices.shape[0]:
        # farthest vertex of each simplex from each centre, minus the shrunk radius: (N, S)
        diff = simplices[:, :, None, :] - centers[None, None, :, :]
        far = np.sqrt(np.einsum("nksi,nksi->nks", diff, diff)).max(axis=1)
        simplices = simplices[~(far + margin <= out).any(axis=1)]
        small = _longest_edges(simplices) <= _LEAF_SIZE
        if 2 * simplices.shape[0] > _MAX_PIECES:  # a large hole: grow balls for every piece
            small[:] = True
        leaves.append(simplices[small])
        simplices = _simplex_pieces(simplices[~small])
    grown = 0
    for piece in np.concatenate(leaves):
        far = np.linalg.norm(piece[:, None, :] - centers[None], axis=-1).max(axis=0)
        if np.any(far + margin <= out):
            continue  # covered by a ball grown for an earlier piece
        s = int(np.argmin(far + margin - out))
        out[s] = far[s] + margin
        grown += 1
    return out, grown


SPHERE_CACHE_ENVIRONMENT_VARIABLE = "TASKSPACE_SPHERE_CACHE"
"""Set to ``0`` to turn the on-disk sphere cache off (:func:`sphere_model`)."""

_SOURCE_DIGEST = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def sphere_cache_directory() -> Path:
    """Directory of the on-disk sphere cache: ``spheres/`` in taskspace's cache directory.

    That is ``$TASKSPACE_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/taskspace`` (default
    ``~/.cache/taskspace``), as for the robot listing.
    """
    from taskspace.model.registry import cache_directory

    return cache_directory() / "spheres"


def _geometry_key(geom: Any, tris: FloatArray, opts: SphereModelOptions) -> str:
    """SHA-256 of everything one geometry's spheres are computed from."""
    digest = hashlib.sha256()
    digest.update(_SOURCE_DIGEST.encode())
    settings = (
        opts.spheres_per_geometry,
        opts.surface_spacing,
        opts.interior_spacing,
        opts.certified_margin,
    )
    digest.update(repr((type(geom).__name__, settings, tris.shape)).encode())
    if isinstance(geom, coal.Capsule):
        digest.update(repr((float(geom.radius), float(geom.halfLength))).encode())
    digest.update(np.ascontiguousarray(tris, dtype=np.float64).tobytes())
    return digest.hexdigest()


def _payload_digest(key: str, centers: FloatArray, radii: FloatArray) -> str:
    digest = hashlib.sha256(key.encode())
    digest.update(np.ascontiguousarray(centers, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(radii, dtype=np.float64).tobytes())
    return digest.hexdigest()


def _read_cached(path: Path, key: str) -> tuple[FloatArray, FloatArray] | None:
    """The cached spheres of ``key``, or ``None`` (absent, unreadable, or failing a check)."""
    try:
        with np.load(path, allow_pickle=False) as f:
            stored_key, stored_digest = str(f["key"]), str(f["digest"])
            centers = np.array(f["centers"], dtype=np.float64)
            radii = np.array(f["radii"], dtype=np.float64)
    except FileNotFoundError:
        return None
    except Exception as exc:  # any unreadable file: recomputed, and said
        logger.warning("sphere cache entry %s unreadable (%s): recomputed", path, exc)
        return None
    ok = (
        stored_key == key
        and centers.ndim == 2
        and centers.shape[1:] == (3,)
        and radii.shape == (centers.shape[0],)
        and centers.shape[0] >= 1
        and bool(np.isfinite(centers).all() and np.isfinite(radii).all())
        and bool((radii > 0.0).all())
        and stored_digest == _payload_digest(key, centers, radii)
    )
    if not ok:
        logger.warning("sphere cache entry %s fails its checks: recomputed", path)
        return None
    return centers, radii


def _write_cached(path: Path, key: str, centers: FloatArray, radii: FloatArray) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.stem}.{os.getpid()}.{threading.get_ident()}.tmp.npz")
        np.savez(
            tmp,
            key=np.array(key),
            digest=np.array(_payload_digest(key, centers, radii)),
            centers=centers,
            radii=radii,
        )
        os.replace(tmp, path)
    except OSError as exc:
        logger.info("cannot write the sphere cache entry %s: %s", path, exc)


def _geometry_spheres(
    geom: Any, name: str, opts: SphereModelOptions, cache: bool
) -> tuple[FloatArray, FloatArray]:
    """Certified spheres of one non-sphere geometry in its own frame (steps 1-5), cached."""
    h, g, eps = opts.surface_spacing, opts.interior_spacing, opts.certified_margin
    tris = surface_triangles(geom, name)
    use_cache = cache and os.environ.get(SPHERE_CACHE_ENVIRONMENT_VARIABLE, "1") != "0"
    if use_cache:
        key = _geometry_key(geom, tris, opts)
        path = sphere_cache_directory() / f"{key[:40]}.npz"
        hit = _read_cached(path, key)
        if hit is not None:
            return hit
        logger.info("spheres of geometry %s: fitting and proving (cached in %s)", name, path)
    pts = _triangle_samples(tris, h)
    # the hull of the triangle corners is the hull of all the surface samples
    pts = np.concatenate([pts, interior_samples(tris.reshape(-1, 3), g)])
    c, r = fit_spheres(pts, opts.spheres_per_geometry, h / math.sqrt(3.0), tris.reshape(-1, 3))
    centers, radii = list(c), list(r)
    if isinstance(geom, coal.Capsule):  # the end caps
        for z in (-geom.halfLength, geom.halfLength):
            centers.append(np.array([0.0, 0.0, float(z)]))
            radii.append(float(geom.radius) + eps)
    # the volume certificate (module docstring, step 5)
    proved, _ = certify_cover(tris, np.asarray(centers), np.asarray(radii), eps)
    out = (np.asarray(centers, dtype=np.float64).reshape(-1, 3), np.asarray(proved, dtype=float))
    if use_cache:
        _write_cached(path, key, *out)
    return out


def sphere_model(
    collision_model: pin.GeometryModel,
    geometries: list[int] | None = None,
    *,
    options: SphereModelOptions | None = None,
    cache: bool = True,
) -> SphereModel:
    """Conservative spheres for geometry objects of ``collision_model`` (module docstring).

    The spheres of each geometry (in its own frame, certificate included) are kept in an
    on-disk cache (:func:`sphere_cache_directory`), keyed by a SHA-256 of what they are
    computed from: the geometry's surface triangles (or primitive sizes), the options and the
    source code of this module; an entry whose content fails its checksum is recomputed. A
    robot's first plan with the sphere checkers then loads its spheres instead of fitting and
    proving them again.

    Args:
        collision_model: the geometry model (e.g. ``robot.collision_model``).
        geometries: indices of the geometry objects to approximate; default all of them (for
            a :class:`~taskspace.model.robot.Robot`, pass
            ``range(robot.robot_geometry_count)`` to leave the obstacles out).
        options: :class:`SphereModelOptions`.
        cache: read and write the on-disk cache (``False``: compute every geometry's
            spheres, write nothing).

    Returns:
        The :class:`SphereModel`, spheres in the parent joint frames.

    Raises:
        InvalidInputError: an unsupported shape, an index out of range, or bad options.
    """
    opts = options or SphereModelOptions()
    if opts.spheres_per_geometry < 1 or isinstance(opts.spheres_per_geometry, bool):
        raise InvalidInputError(
            f"spheres_per_geometry must be an integer >= 1, got {opts.spheres_per_geometry!r}"
        )
    h = check_positive(opts.surface_spacing, "surface_spacing")
    check_positive(opts.interior_spacing, "interior_spacing")
    eps = check_positive(opts.certified_margin, "certified_margin")
    objs = collision_model.geometryObjects
    indices = list(range(len(objs))) if geometries is None else [int(i) for i in geometries]
    centers, radii, joints, geoms, names = [], [], [], [], []
    for gi in indices:
        if not 0 <= gi < len(objs):
            raise InvalidInputError(
                f"geometry index {gi} out of range: the model has {len(objs)} objects"
            )
        obj = objs[gi]
        geom = obj.geometry
        placement = obj.placement  # geometry frame in the parent joint frame
        swept = float(geom.getSweptSphereRadius()) if hasattr(geom, "getSweptSphereRadius") else 0.0
        if isinstance(geom, coal.Sphere):
            local_c, local_r = np.zeros((1, 3)), np.array([float(geom.radius) + eps])
        else:
            local_c, local_r = _geometry_spheres(geom, obj.name, opts, cache)
        for c_loc, r_loc in zip(local_c, local_r):
            centers.append(placement.rotation @ c_loc + placement.translation)
            radii.append(r_loc + swept)
            joints.append(obj.parentJoint)
            geoms.append(gi)
            names.append(obj.name)
    return SphereModel(
        centers=np.asarray(centers, dtype=float).reshape(-1, 3),
        radii=np.asarray(radii, dtype=float),
        joints=np.asarray(joints, dtype=np.int64),
        geometries=np.asarray(geoms, dtype=np.int64),
        names=tuple(names),
        covering_radius=h / math.sqrt(3.0),
        certified_margin=eps,
    )


OBSTACLE_SHAPES = ("Box", "Sphere", "Cylinder", "Capsule")
"""Obstacle geometry types :func:`obstacle_signed_distances` handles."""


def _point_shape_distance(points: FloatArray, geometry: coal.CollisionGeometry, name: str) -> Any:
    """Signed distance [m] from points ``(n, 3)`` (shape frame) to a primitive (< 0 inside)."""
    if isinstance(geometry, coal.Sphere):
        return np.linalg.norm(points, axis=1) - float(geometry.radius)
    if isinstance(geometry, coal.Box):
        q = np.abs(points) - np.asarray(geometry.halfSide, dtype=float)
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        return outside + np.minimum(q.max(axis=1), 0.0)
    if isinstance(geometry, coal.Cylinder):
        d_rad = np.hypot(points[:, 0], points[:, 1]) - float(geometry.radius)
        d_ax = np.abs(points[:, 2]) - float(geometry.halfLength)
        outside = np.hypot(np.maximum(d_rad, 0.0), np.maximum(d_ax, 0.0))
        return outside + np.minimum(np.maximum(d_rad, d_ax), 0.0)
    if isinstance(geometry, coal.Capsule):
        hl = float(geometry.halfLength)
        z = np.clip(points[:, 2], -hl, hl)
        seg = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
        return np.linalg.norm(points - seg, axis=1) - float(geometry.radius)
    raise InvalidInputError(
        f"obstacle '{name}' is a {type(geometry).__name__}; the sphere check handles: "
        f"{', '.join(OBSTACLE_SHAPES)}"
    )


def obstacle_signed_distances(
    spheres: SphereModel, model: pin.Model, obstacles: Sequence[Obstacle], qs: Any
) -> FloatArray:
    """Least signed distance between the spheres and the obstacles, per configuration.

    ``min over spheres k and obstacles o of sd_o(oMi[joint_k] * c_k) - r_k`` with ``sd_o``
    the exact signed distance from a point to obstacle ``o`` (box, sphere, cylinder,
    capsule): negative when some sphere penetrates some obstacle.

    Args:
        spheres: the robot's :class:`SphereModel`.
        model: the Pinocchio model the spheres' joint indices refer to.
        obstacles: the obstacles (e.g. ``robot.world.obstacles``).
        qs: configurations ``(B, nq)``.

    Returns:
        Distances ``(B,)`` [m] (``inf`` without obstacles or spheres).

    Raises:
        InvalidInputError: an obstacle of another shape (the message lists the handled ones).
    """
    q_all = as_matrix(qs, (None, model.nq), "qs")
    data = model.createData()
    out = np.full(q_all.shape[0], np.inf)
    for b, q in enumerate(q_all):
        pin.forwardKinematics(model, data, q)
        centers = spheres.world_centers(data)
        for obs in obstacles:
            m = obs.placement
            local = (centers - m.translation) @ m.rotation  # R^T (c - t), row-wise
            d = _point_shape_distance(local, obs.geometry, obs.name) - spheres.radii
            if d.size:
                out[b] = min(out[b], float(d.min()))
    return out


def spheres_hit_obstacles(
    spheres: SphereModel, model: pin.Model, obstacles: Sequence[Obstacle], qs: Any
) -> BoolArray:
    """Whether some sphere touches some obstacle, per configuration ``(B,)``.

    Conservative: ``False`` implies that the geometry the spheres cover is free of the
    obstacles (:func:`obstacle_signed_distances` > 0).
    """
    return np.asarray(obstacle_signed_distances(spheres, model, obstacles, qs) <= 0.0)
