"""Convex collision geometry: qhull hulls, and a mesh coal cannot hull keeps its mesh."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import ModelWarning
from taskspace.model.robot import _convexify


def _mesh(vertices: np.ndarray, triangles: np.ndarray) -> coal.BVHModelOBBRSS:
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(triangles), len(vertices))
    for v in vertices:
        m.addVertex(np.asarray(v, dtype=float))
    for t in triangles:
        m.addTriangle(*(np.asarray(vertices[k], dtype=float) for k in t))
    m.endModel()
    return m


def _cone(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A cone with n base vertices: its apex has n neighbours on the hull."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    base = np.c_[np.cos(a), np.sin(a), np.zeros(n)]
    verts = np.vstack([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], base])
    tris = [(0, 2 + i, 2 + (i + 1) % n) for i in range(n)]
    tris += [(1, 2 + (i + 1) % n, 2 + i) for i in range(n)]
    return verts, np.array(tris)


def _geometry_model(*meshes: coal.BVHModelOBBRSS) -> pin.GeometryModel:
    gm = pin.GeometryModel()
    for k, m in enumerate(meshes):
        gm.addGeometryObject(pin.GeometryObject(f"g{k}", 0, pin.SE3.Identity(), m))
    return gm


def test_hull_of_a_non_convex_triangulation_contains_every_vertex() -> None:
    # a cube whose top face is dented: its own triangles are not a convex polytope
    verts = np.array(
        [[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)] + [[0.5, 0.5, 0.8]]
    )
    sides = [(0, 2, 1), (1, 2, 3), (0, 1, 5), (0, 5, 4), (1, 3, 7), (1, 7, 5)]
    sides += [(3, 2, 6), (3, 6, 7), (2, 0, 4), (2, 4, 6)]
    dent = [(4, 5, 8), (5, 7, 8), (7, 6, 8), (6, 4, 8)]
    tris = np.array(sides + dent)
    gm = _geometry_model(_mesh(verts, tris))
    _convexify(gm)
    convex = gm.geometryObjects[0].geometry
    assert isinstance(convex, coal.ConvexBase)
    points = np.asarray(convex.points())
    # the dent's vertex is strictly inside the hull: not one of its points
    assert len(points) == 8
    assert not np.any(np.all(np.isclose(points, [0.5, 0.5, 0.8]), axis=1))


def test_mesh_that_coal_cannot_hull_keeps_its_mesh_with_a_warning() -> None:
    verts, tris = _cone(300)
    cube = _mesh(*_cone(8))
    gm = _geometry_model(_mesh(verts, tris), cube)
    with pytest.warns(ModelWarning, match="'g0' keeps its mesh"):
        _convexify(gm)
    assert isinstance(gm.geometryObjects[0].geometry, coal.BVHModelBase)
    assert isinstance(gm.geometryObjects[1].geometry, coal.ConvexBase)
