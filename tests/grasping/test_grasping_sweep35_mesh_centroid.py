"""Grasp epsilon of sampled grasps: torques about the object's center of mass (sweep35).

The samplers took torques about the mean of the mesh vertices. On an unevenly tessellated
mesh that is not the center of mass: a box whose +x side is a fine grid has its vertex mean
near that side, and every epsilon was computed about that point, silently. References: the
analytic center of a box and of a tetrahedron, and the epsilon from scipy's convex hull of
the primitive wrenches about the true center.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from taskspace.grasping import (
    AntipodalOptions,
    MultiFingerOptions,
    TriangleMesh,
    primitive_wrenches_batch,
    sample_antipodal_grasps,
    sample_multifinger_grasps,
)

HALF = np.array([0.05, 0.03, 0.02])  # half sides of the box [m]; its center of mass is 0


def _refined_box(n: int = 12) -> TriangleMesh:
    """The box [-HALF, HALF], its +x side an n x n grid, the other five sides two triangles."""
    vertices: list[np.ndarray] = []
    faces: list[list[int]] = []

    def quad_grid(origin: np.ndarray, du: np.ndarray, dv: np.ndarray, cells: int) -> None:
        base = len(vertices)
        for i in range(cells + 1):
            for j in range(cells + 1):
                vertices.append(origin + du * i / cells + dv * j / cells)
        for i in range(cells):
            for j in range(cells):
                a = base + i * (cells + 1) + j
                b, c, d = a + cells + 1, a + 1, a + cells + 2
                faces.extend([[a, b, d], [a, d, c]])  # (du x dv) is the outward side

    hx, hy, hz = HALF
    ex, ey, ez = np.array([2 * hx, 0, 0]), np.array([0, 2 * hy, 0]), np.array([0, 0, 2 * hz])
    quad_grid(np.array([hx, -hy, -hz]), ey, ez, n)  # +x (fine)
    quad_grid(np.array([-hx, -hy, -hz]), ez, ey, 1)  # -x
    quad_grid(np.array([-hx, hy, -hz]), ez, ex, 1)  # +y
    quad_grid(np.array([-hx, -hy, -hz]), ex, ez, 1)  # -y
    quad_grid(np.array([-hx, -hy, hz]), ex, ey, 1)  # +z
    quad_grid(np.array([-hx, -hy, -hz]), ey, ex, 1)  # -z
    return TriangleMesh(np.array(vertices), np.array(faces))


def _epsilon_about(points: np.ndarray, normals: np.ndarray, center: np.ndarray, **kw) -> float:
    """Epsilon (L1) from scipy's hull of the primitive wrenches about ``center``."""
    W = primitive_wrenches_batch(points[None], normals[None], center=center, **kw)[0]
    hull = ConvexHull(W)
    return max(0.0, float(-hull.equations[:, -1].max()))


def test_centroid_is_the_center_of_mass() -> None:
    box = _refined_box()
    assert np.linalg.norm(box.vertices.mean(axis=0)) > 0.02  # the vertex mean is pulled to +x
    np.testing.assert_allclose(box.centroid, np.zeros(3), atol=1e-15)
    tet = np.array([[0.1, 0.0, 0.0], [0.4, 0.0, 0.1], [0.0, 0.3, 0.0], [0.1, 0.1, 0.5]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    for f in (faces, faces[:, ::-1]):  # either orientation
        np.testing.assert_allclose(TriangleMesh(tet, f).centroid, tet.mean(axis=0), atol=1e-15)


def test_antipodal_epsilon_about_the_center_of_mass() -> None:
    box = _refined_box()
    o = AntipodalOptions(samples=60, max_width=0.2)
    cands = sample_antipodal_grasps(box, np.random.default_rng(0), o)
    assert len(cands) > 5
    for i in range(len(cands)):
        points = np.stack([cands.p1[i], cands.p2[i]])
        normals = np.stack([cands.n1[i], cands.n2[i]])
        ref = _epsilon_about(
            points, normals, np.zeros(3), mu=o.mu, edges=o.edges, torsion=o.torsion
        )
        assert abs(cands.epsilon[i] - ref) <= 1e-9, (i, cands.epsilon[i], ref)


def test_multifinger_epsilon_about_the_center_of_mass() -> None:
    box = _refined_box()
    o = MultiFingerOptions(samples=150)
    cands = sample_multifinger_grasps(box, np.random.default_rng(1), o)
    assert len(cands) > 3
    np.testing.assert_allclose(cands.center, np.zeros(3), atol=1e-15)
    for i in range(len(cands)):
        ref = _epsilon_about(cands.points[i], cands.normals[i], np.zeros(3), mu=o.mu, edges=o.edges)
        assert abs(cands.epsilon[i] - ref) <= 1e-9, (i, cands.epsilon[i], ref)
