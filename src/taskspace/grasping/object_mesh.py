"""Triangle meshes of grasped objects: primitives, surface sampling, ray casting, coal models.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import numpy.typing as npt

from taskspace._validation import (
    as_float_array,
    as_matrix,
    as_vector,
    check_count,
    check_positive,
)
from taskspace.errors import InvalidInputError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class TriangleMesh:
    """A closed triangle mesh with outward-facing (counter-clockwise) triangles.

    Attributes:
        vertices: ``(V, 3)`` [m].
        faces: ``(F, 3)`` vertex indices.
    """

    vertices: FloatArray
    faces: npt.NDArray[np.int64]

    def __post_init__(self) -> None:
        v = as_float_array(self.vertices, "vertices")
        f = np.asarray(self.faces)
        if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
            raise InvalidInputError(f"vertices must be finite (V, 3), got {v.shape}")
        # integer indices only: floats were truncated (2.5 -> 2) and booleans taken as 0/1
        # silently, strings failed inside numpy; integral floats (from a loader) are fine
        integral = f.dtype.kind in "iu" or (
            f.dtype.kind == "f" and bool(np.all(np.isfinite(f))) and bool(np.all(f == np.round(f)))
        )
        if (
            not integral
            or f.ndim != 2
            or f.shape[1] != 3
            or f.size == 0
            or f.min() < 0
            or f.max() >= len(v)
        ):
            raise InvalidInputError(
                f"faces must be (F, 3) integer indices of the {len(v)} vertices, got "
                f"shape {f.shape} of dtype {f.dtype}"
            )
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f.astype(np.int64))

    @property
    def triangles(self) -> FloatArray:
        """``(F, 3, 3)``: the corners of each face."""
        return self.vertices[self.faces]

    @property
    def face_normals(self) -> FloatArray:
        """Outward unit normals ``(F, 3)``."""
        t = self.triangles
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    @property
    def areas(self) -> FloatArray:
        """Face areas ``(F,)`` [m^2]."""
        t = self.triangles
        return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)

    @property
    def centroid(self) -> FloatArray:
        """Center of mass ``(3,)`` of the enclosed solid at uniform density [m].

        By the divergence theorem, from the tetrahedra joining a reference point ``o`` (the
        vertex mean) to each face ``(a, b, c)``: signed volumes ``V_f = det(a-o, b-o, c-o) / 6``
        and ``c = o + sum_f V_f (a + b + c - 3 o) / 4 / sum_f V_f``. The vertex mean itself is
        not the center of mass when the tessellation is uneven (a finely meshed side pulls it
        over). A mesh enclosing no volume (flat or open) gives the area-weighted centroid of
        its surface.
        """
        t = self.triangles
        o = self.vertices.mean(axis=0)
        r = t - o
        det = np.einsum("fi,fi->f", r[:, 0], np.cross(r[:, 1], r[:, 2]))
        volume = float(det.sum())
        extent = float(np.ptp(self.vertices, axis=0).max())
        if abs(volume) > 1e-9 * extent**3:
            return np.asarray(o + (det @ r.sum(axis=1)) / (4.0 * volume))
        areas = self.areas
        return np.asarray((areas @ t.mean(axis=1)) / areas.sum())

    def sample_surface(
        self, n: int, rng: np.random.Generator
    ) -> tuple[FloatArray, FloatArray, npt.NDArray[np.int64]]:
        """``n`` points uniform over the surface: ``(points, outward normals, face indices)``."""
        n = check_count(n, "n")
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
                f"{type(rng).__name__}"
            )
        areas = self.areas
        if not areas.sum() > 0:
            raise InvalidInputError("the mesh has zero surface area: no point to sample")
        faces = rng.choice(len(areas), size=n, p=areas / areas.sum())
        u, v = rng.random(n), rng.random(n)
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        t = self.triangles[faces]
        points = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
        return points, self.face_normals[faces], faces

    def ray_exit(
        self, origins: FloatArray, directions: FloatArray, eps: float = 1e-9
    ) -> tuple[FloatArray, npt.NDArray[np.int64]]:
        """Farthest hit of each ray with the mesh (Moller-Trumbore, every face at once).

        Returns:
            ``(t, face)``: ray parameter of the last crossing (NaN when the ray misses) and the
            face crossed there (-1 when it misses).
        """
        origins = as_matrix(origins, (None, 3), "origins")
        directions = as_matrix(directions, (origins.shape[0], 3), "directions")
        t = self.triangles  # (F, 3, 3)
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        d = directions[:, None, :]  # (R, 1, 3)
        p = np.cross(d, e2[None])  # (R, F, 3)
        det = np.einsum("rfk,fk->rf", p, e1)
        ok = np.abs(det) > eps
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = origins[:, None, :] - t[None, :, 0]
        u = np.einsum("rfk,rfk->rf", s, p) * inv
        qv = np.cross(s, e1[None])
        v = np.einsum("rk,rfk->rf", directions, qv) * inv
        dist = np.einsum("fk,rfk->rf", e2, qv) * inv
        hit = ok & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps) & (dist > 1e-7)
        dist = np.where(hit, dist, -np.inf)
        face = np.argmax(dist, axis=1)
        best = dist[np.arange(len(dist)), face]
        missed = ~np.isfinite(best)
        return np.where(missed, np.nan, best), np.where(missed, -1, face)

    def collision_geometry(self) -> coal.BVHModelOBBRSS:
        """The mesh as a coal BVH model (for collision checks and distances)."""
        model = coal.BVHModelOBBRSS()
        model.beginModel(len(self.faces), len(self.vertices))
        for vertex in self.vertices:
            model.addVertex(vertex)
        for face in self.faces:
            model.addTriangle(*(self.vertices[i] for i in face))
        model.endModel()
        return model


def box_mesh(size: FloatArray) -> TriangleMesh:
    """A box of full side lengths ``size`` [m] centered at the origin."""
    s = as_vector(as_float_array(size, "size").reshape(-1), 3, "size") / 2
    if np.any(s <= 0):
        raise InvalidInputError(f"box size must be 3 side lengths > 0 [m], got {2 * s}")
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * s
    faces = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    return _outward(TriangleMesh(corners, faces))


def cylinder_mesh(radius: float, length: float, segments: int = 32) -> TriangleMesh:
    """A cylinder along z, centered at the origin (``segments`` sides)."""
    radius = _length(radius, "radius")
    length = _length(length, "length")
    segments = check_count(segments, "segments", minimum=3)
    a = 2 * np.pi * np.arange(segments) / segments
    ring = np.column_stack([radius * np.cos(a), radius * np.sin(a)])
    bottom = np.column_stack([ring, np.full(segments, -length / 2)])
    top = np.column_stack([ring, np.full(segments, length / 2)])
    vertices = np.vstack([bottom, top, [[0, 0, -length / 2], [0, 0, length / 2]]])
    faces = []
    for i in range(segments):
        j = (i + 1) % segments
        faces += [[i, j, segments + j], [i, segments + j, segments + i]]
        faces += [[2 * segments, j, i], [2 * segments + 1, segments + i, segments + j]]
    return _outward(TriangleMesh(vertices, np.array(faces)))


def sphere_mesh(radius: float, subdivisions: int = 2) -> TriangleMesh:
    """An icosphere of ``radius`` [m] (``20 * 4**subdivisions`` faces; at most 7 subdivisions)."""
    radius = _length(radius, "radius")
    subdivisions = check_count(subdivisions, "subdivisions")
    if subdivisions > 7:
        raise InvalidInputError(
            f"subdivisions must be at most 7 (327680 faces), got {subdivisions}"
        )
    g = (1 + 5**0.5) / 2
    v = [[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
         [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]]  # fmt: skip
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]  # fmt: skip
    vertices = [np.array(x, float) / np.linalg.norm(x) for x in v]
    faces = f
    for _ in range(subdivisions):
        cache: dict[tuple[int, int], int] = {}

        def mid(i: int, j: int, cache: dict[tuple[int, int], int] = cache) -> int:
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = vertices[i] + vertices[j]
                vertices.append(m / np.linalg.norm(m))
                cache[key] = len(vertices) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        faces = new
    return _outward(TriangleMesh(np.array(vertices) * radius, np.array(faces)))


def _length(value: object, name: str) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be a length > 0 [m], got {value!r}")
    return check_positive(value, f"{name} [m]")


def _outward(mesh: TriangleMesh) -> TriangleMesh:
    """Orient every face outward (the mesh is star-shaped about its centroid)."""
    center = mesh.vertices.mean(axis=0)
    t = mesh.triangles
    outward = np.einsum("fk,fk->f", mesh.face_normals, t.mean(axis=1) - center) > 0
    faces = mesh.faces.copy()
    faces[~outward] = faces[~outward][:, [0, 2, 1]]
    return TriangleMesh(mesh.vertices, faces)
