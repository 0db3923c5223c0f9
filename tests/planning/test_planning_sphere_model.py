"""Sphere models contain their geometry (issue 22, item 4): Panda and UR5 meshes, convex hulls,
primitives; in the joint frames and in the world at random configurations (Pinocchio's
geometry placements). The points checked are taken from coal's geometry directly (vertices,
random points on its triangles, random points inside convex hulls and primitives), not from
the samples the spheres were fitted to.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON

from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.model.robot import Robot
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from taskspace.planning.sphere_model import (
    SphereModel,
    SphereModelOptions,
    obstacle_signed_distances,
    sphere_model,
    spheres_hit_obstacles,
)

FAST = SphereModelOptions(spheres_per_geometry=10, surface_spacing=0.006, interior_spacing=0.015)


def _outside(points: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Signed distance of every point to the union of the spheres (> 0: outside)."""
    d = np.linalg.norm(points[:, None, :] - centers[None], axis=2) - radii[None]
    return np.asarray(d.min(axis=1))


def _mesh(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a coal mesh or convex hull."""
    if isinstance(geometry, coal.BVHModelBase):
        v = np.asarray(geometry.vertices())
        tri = [geometry.tri_indices(i) for i in range(geometry.num_tris)]
    else:
        v = np.asarray(geometry.points())
        tri = [geometry.polygons(i) for i in range(geometry.num_polygons)]
    return v, np.array([[t[0], t[1], t[2]] for t in tri])


def _surface_points(v: np.ndarray, tri: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    k = rng.integers(0, len(tri), n)
    w = rng.dirichlet(np.ones(3), n)
    return np.einsum("nk,nkd->nd", w, v[tri[k]])


def _geometry_points(
    geometry: coal.CollisionGeometry, n: int, rng: np.random.Generator
) -> np.ndarray:
    """Vertices and random surface points of a mesh, or random points of a primitive."""
    if isinstance(geometry, (coal.BVHModelBase, coal.ConvexBase)):
        v, tri = _mesh(geometry)
        return np.concatenate([v, _surface_points(v, tri, n, rng)])
    return _primitive_points(geometry, n, rng)


@pytest.fixture(scope="module", params=["panda", "ur5"])
def robot_spheres(request: pytest.FixtureRequest) -> tuple[Robot, SphereModel]:
    robot = Robot.load(request.param)
    options = SphereModelOptions() if request.param == "panda" else FAST
    return robot, sphere_model(
        robot.collision_model, range(robot.robot_geometry_count), options=options
    )


def test_every_vertex_and_surface_point_is_inside_in_the_joint_frame(robot_spheres) -> None:  # type: ignore[no-untyped-def]
    robot, spheres = robot_spheres
    rng = np.random.default_rng(0)
    n_meshes = 0
    for gi in range(robot.robot_geometry_count):
        obj = robot.collision_model.geometryObjects[gi]
        n_meshes += isinstance(obj.geometry, coal.BVHModelBase)
        pts = _geometry_points(obj.geometry, 3000, rng)
        pts = pts @ obj.placement.rotation.T + obj.placement.translation  # joint frame
        sel = spheres.geometries == gi
        assert sel.sum() >= 1 and np.all(spheres.joints[sel] == obj.parentJoint)
        out = _outside(pts, spheres.centers[sel], spheres.radii[sel])
        assert out.max() <= 0.0, obj.name
        if isinstance(obj.geometry, coal.BVHModelBase):  # the vertices with the margin rho
            n_vertices = obj.geometry.num_vertices
            assert out[:n_vertices].max() <= -spheres.covering_radius + 1e-9, obj.name
        # not needlessly large: some point is within 3 cm of a sphere's surface
        assert out.max() > -0.03, obj.name
    assert n_meshes >= 7
    assert spheres.count == len(spheres.names) == spheres.centers.shape[0]


def test_contains_the_geometry_in_the_world_at_random_configurations(robot_spheres) -> None:  # type: ignore[no-untyped-def]
    robot, spheres = robot_spheres
    model, data = robot.model, robot.model.createData()
    gdata = robot.collision_model.createData()
    rng = np.random.default_rng(1)
    for _ in range(3):
        q = pin.randomConfiguration(model)
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, robot.collision_model, gdata)
        world = spheres.world_centers(data)
        for gi in range(robot.robot_geometry_count):
            geometry = robot.collision_model.geometryObjects[gi].geometry
            pts = _geometry_points(geometry, 500, rng)
            m = gdata.oMg[gi]
            pts = pts @ m.rotation.T + m.translation
            sel = spheres.geometries == gi
            assert _outside(pts, world[sel], spheres.radii[sel]).max() <= 0.0


@pytest.mark.parametrize("name", ["panda", "ur5"])  # the UR5's upper arm is a long tube
def test_convex_hull_interiors_are_covered(name: str) -> None:
    robot = Robot.load(name, convex_collision=True)
    spheres = sphere_model(robot.collision_model, range(robot.robot_geometry_count), options=FAST)
    rng = np.random.default_rng(2)
    checked = 0
    for gi in range(robot.robot_geometry_count):
        obj = robot.collision_model.geometryObjects[gi]
        if not isinstance(obj.geometry, coal.ConvexBase):
            continue
        v = np.asarray(obj.geometry.points())
        w = rng.dirichlet(np.full(4, 0.5), 5000)
        pts = np.einsum("nk,nkd->nd", w, v[rng.integers(0, len(v), (5000, 4))])
        pts = pts @ obj.placement.rotation.T + obj.placement.translation
        sel = spheres.geometries == gi
        assert _outside(pts, spheres.centers[sel], spheres.radii[sel]).max() <= 0.0, obj.name
        checked += 1
    assert checked >= 6


def _primitive_points(
    geometry: coal.CollisionGeometry, n: int, rng: np.random.Generator
) -> np.ndarray:
    """Random points inside and on the surface of a primitive, in its frame."""
    if isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide)
        inside = rng.uniform(-h, h, (n, 3))
        surface = inside.copy()
        axis = rng.integers(0, 3, n)
        surface[np.arange(n), axis] = h[axis] * rng.choice([-1.0, 1.0], n)
        return np.concatenate([inside, surface])
    r, hl = float(geometry.radius), float(getattr(geometry, "halfLength", 0.0))
    ang = rng.uniform(0, 2 * np.pi, n)
    rad = r * np.sqrt(rng.uniform(0, 1, n))
    z = rng.uniform(-hl, hl, n)
    pts = [np.stack([rad * np.cos(ang), rad * np.sin(ang), z], 1)]
    pts.append(np.stack([r * np.cos(ang), r * np.sin(ang), z], 1))  # the side
    if isinstance(geometry, (coal.Capsule, coal.Sphere)):
        u = rng.normal(size=(n, 3))
        u *= (r * rng.uniform(0, 1, n) ** (1 / 3) / np.linalg.norm(u, axis=1))[:, None]
        cap = np.array([0.0, 0.0, hl])
        pts += [u + cap, u - cap]
    return np.concatenate(pts)


def test_primitives_are_contained() -> None:
    shapes = [coal.Box(0.3, 0.1, 0.05), coal.Cylinder(0.04, 0.5), coal.Capsule(0.05, 0.3)]
    shapes.append(coal.Sphere(0.07))
    gm = pin.GeometryModel()
    placement = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.1), np.array([0.1, -0.2, 0.3]))
    for i, shape in enumerate(shapes):
        gm.addGeometryObject(pin.GeometryObject(f"shape{i}", 2, 0, placement, shape))
    spheres = sphere_model(gm, options=FAST)
    rng = np.random.default_rng(3)
    for i, shape in enumerate(shapes):
        pts = _primitive_points(shape, 4000, rng) @ placement.rotation.T + placement.translation
        centers, radii = spheres.of_geometry(f"shape{i}")
        assert _outside(pts, centers, radii).max() <= 1e-12, type(shape).__name__
    assert set(spheres.joints) == {2}
    centers, radii = spheres.of_geometry("shape3")  # a sphere is kept, plus the margin
    np.testing.assert_allclose(centers, [placement.translation])
    np.testing.assert_allclose(radii, [0.07 + spheres.certified_margin], rtol=0, atol=1e-15)


def test_bad_inputs_raise_taskspace_errors() -> None:
    gm = pin.GeometryModel()
    gm.addGeometryObject(pin.GeometryObject("cone", 1, 0, pin.SE3.Identity(), coal.Cone(0.1, 0.2)))
    with pytest.raises(InvalidInputError, match="Cone; sphere models support: mesh"):
        sphere_model(gm)
    with pytest.raises(InvalidInputError, match="out of range"):
        sphere_model(gm, [3])
    with pytest.raises(InvalidInputError, match="spheres_per_geometry"):
        sphere_model(gm, [], options=SphereModelOptions(spheres_per_geometry=0))
    with pytest.raises(InvalidInputError, match="surface_spacing"):
        sphere_model(gm, [], options=SphereModelOptions(surface_spacing=-1.0))
    empty = sphere_model(gm, [])
    assert empty.count == 0
    with pytest.raises(UnknownNameError, match="valid geometrys are"):
        empty.of_geometry("link")


# ------------------------------------------------------------- spheres against the obstacles
def _mesh_hits(robot: Robot, gdata: pin.GeometryData) -> bool:
    """Exact robot-obstacle collision with coal (robot geometries against obstacles)."""
    objs = robot.collision_model.geometryObjects
    req, res = coal.CollisionRequest(), coal.CollisionResult()
    n = robot.robot_geometry_count
    for gi in range(n):
        for oi in range(n, len(objs)):
            res.clear()
            if coal.collide(
                objs[gi].geometry, gdata.oMg[gi], objs[oi].geometry, gdata.oMg[oi], req, res
            ):
                return True
    return False


@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
@pytest.mark.parametrize("scenario", ["bookshelf_small", "table_pick"])
def test_sphere_check_never_frees_a_colliding_configuration(scenario: str) -> None:
    robot = motionbenchmaker_panda()
    motionbenchmaker_problems(ROOT, scenario, [1])[0].apply(robot)
    spheres = sphere_model(robot.collision_model, range(robot.robot_geometry_count), options=FAST)
    obstacles = list(robot.world)
    rng = np.random.default_rng(4)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (80, robot.model.nq))
    sd = obstacle_signed_distances(spheres, robot.model, obstacles, qs)
    hits = spheres_hit_obstacles(spheres, robot.model, obstacles, qs)
    np.testing.assert_array_equal(hits, sd <= 0.0)
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    mesh = np.zeros(len(qs), bool)
    for b, q in enumerate(qs):
        pin.updateGeometryPlacements(robot.model, data, robot.collision_model, gdata, q)
        mesh[b] = _mesh_hits(robot, gdata)
        if b < 10:  # the least distance against coal's, sphere by sphere
            world = spheres.world_centers(data)
            best = np.inf
            for k in range(spheres.count):
                ball = coal.Sphere(float(spheres.radii[k]))
                for obs in obstacles:
                    r = coal.DistanceResult()
                    place = pin.SE3(np.eye(3), world[k])
                    coal.distance(
                        ball, place, obs.geometry, obs.placement, coal.DistanceRequest(), r
                    )
                    best = min(best, r.min_distance)
            if best > 1e-6:
                assert sd[b] == pytest.approx(best, abs=1e-6)
            else:
                assert sd[b] <= 1e-6
    assert mesh.any() and (~mesh).any()  # both cases occur
    assert np.all(hits[mesh])  # never "free" where the meshes collide
    # Configurations that just touch: bisect segments from a free to a colliding
    # configuration (mesh check) down to 1e-6 rad; the colliding end must hit the spheres.
    free, hit = qs[~mesh][:8], qs[mesh][:8]
    touching = []
    for a, b in zip(free, hit):
        lo_t, hi_t = 0.0, 1.0
        while hi_t - lo_t > 1e-6 / max(1.0, float(np.abs(b - a).max())):
            mid = 0.5 * (lo_t + hi_t)
            pin.updateGeometryPlacements(
                robot.model, data, robot.collision_model, gdata, a + mid * (b - a)
            )
            lo_t, hi_t = (lo_t, mid) if _mesh_hits(robot, gdata) else (mid, hi_t)
        touching.append(a + hi_t * (b - a))
    assert np.all(spheres_hit_obstacles(spheres, robot.model, obstacles, touching))
