"""The sphere model's volume certificate (sphere_model.certify_cover).

Claim: every point of each geometry's convex hull lies at least ``certified_margin`` inside
the union of the geometry's spheres. Reference: dense random points of the hulls' volumes
(uniform in the bounding box, kept inside the hull by scipy's qhull facet equations, plus the
hull's vertices and facet points), tested against the spheres directly. A hollow cover (balls
around the surface only) must be detected and repaired.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from taskspace.planning.scene_loader import motionbenchmaker_panda
from taskspace.planning.sphere_model import (
    SphereModelOptions,
    _box,
    certify_cover,
    sphere_model,
    surface_triangles,
)


def _hull_points(corners: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
    """Random points of the convex hull of ``corners``: volume, facets and vertices."""
    hull = ConvexHull(corners)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    box = rng.uniform(lo, hi, (count, 3))
    eq = hull.equations
    inside = box[np.all(box @ eq[:, :3].T + eq[:, 3] <= 0.0, axis=1)]
    tri = corners[hull.simplices]
    w = rng.dirichlet(np.ones(3), len(tri) * 20)
    facets = np.einsum("nk,nki->ni", w, np.repeat(tri, 20, axis=0))
    return np.vstack([inside, facets, corners[hull.vertices]])


def _depth(points: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """How far each point lies inside the union of the balls (< 0: outside all of them)."""
    d = np.linalg.norm(points[:, None, :] - centers[None], axis=-1)
    return np.asarray((radii[None] - d).max(axis=1))


def test_a_hollow_cover_is_detected_and_repaired() -> None:
    """26 balls around the surface of a cube leave its centre uncovered: the proof must grow
    a ball (a surface-only certificate would pass it), and then cover every point."""
    tris = _box(np.ones(3))
    grid = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
    centers = grid[np.any(grid != 0, axis=1)].astype(float)
    radii = np.full(len(centers), 0.75)
    rng = np.random.default_rng(0)
    pts = _hull_points(tris.reshape(-1, 3), rng, 40_000)
    faces = pts[np.abs(pts).max(axis=1) > 1.0 - 1e-12]
    assert _depth(faces, centers, radii).min() > 0.0  # the surface is covered...
    assert _depth(np.zeros((1, 3)), centers, radii)[0] < 0.0  # ...the centre is not
    margin = 1e-5
    grown_radii, grown = certify_cover(tris, centers, radii, margin)
    assert grown > 0 and np.all(grown_radii >= radii)
    assert _depth(np.vstack([pts, np.zeros((1, 3))]), centers, grown_radii).min() >= margin


def test_a_full_cover_is_proved_unchanged() -> None:
    """Eight balls, each circumscribing one octant of the cube (plus 1 mm): no growth."""
    tris = _box(np.ones(3))
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    centers = 0.5 * signs
    radii = np.full(8, 0.5 * math.sqrt(3.0) + 1e-3)
    out, grown = certify_cover(tris, centers, radii, 1e-5)
    assert grown == 0
    np.testing.assert_array_equal(out, radii)
    # with the margin larger than the slack, the octants' corners need growth
    _, grown = certify_cover(tris, centers, radii, 2e-3)
    assert grown > 0


def test_panda_spheres_contain_the_hulls() -> None:
    """Every moving geometry of the MotionBenchMaker Panda: its convex hull (vertices, facet
    points and 20,000 random volume points) lies ``certified_margin`` inside its spheres."""
    robot = motionbenchmaker_panda()
    gm = robot.collision_model
    moving = [i for i, o in enumerate(gm.geometryObjects) if o.parentJoint != 0]
    spheres = sphere_model(gm, moving, options=SphereModelOptions())
    assert spheres.certified_margin == 1e-5
    rng = np.random.default_rng(1)
    for gi in moving:
        obj = gm.geometryObjects[gi]
        corners = surface_triangles(obj.geometry, obj.name).reshape(-1, 3)
        pts = _hull_points(corners, rng, 20_000)
        joint_pts = pts @ obj.placement.rotation.T + obj.placement.translation
        sel = spheres.geometries == gi
        depth = _depth(joint_pts, spheres.centers[sel], spheres.radii[sel])
        assert depth.min() >= spheres.certified_margin - 1e-12, obj.name


def test_bad_margin() -> None:
    from taskspace.errors import InvalidInputError

    robot = motionbenchmaker_panda()
    with pytest.raises(InvalidInputError, match="certified_margin"):
        sphere_model(robot.collision_model, [1], options=SphereModelOptions(certified_margin=0))
