"""The robot's coal shapes are its own: a shape modified in place elsewhere cannot reach it.

Issue #15 item 1 ("invalidation by construction"). ``pin.GeometryModel.copy()`` shares the coal
shapes, and every coal shape can be modified in place from Python (``Box.halfSide[:]``,
``Sphere.radius``, ``Ellipsoid.radii[:]``, ``Halfspace.d``, a BVH model's ``replaceVertex``, a
convex polytope's ``points()``, ``HeightField.updateHeights``, ``OcTree.setOccupancyThres``).
``robot.collision_model`` hands out clones, :meth:`Robot.add_obstacle` keeps a clone of the
obstacle's shape and :meth:`Robot.edit_collision_model` writes clones, so none of these routes
changes what the robot and its checkers answer; the sanctioned route still edits the robot.

Reference: Pinocchio's ``computeCollisions`` / ``computeDistances`` on a second, untouched robot
loaded the same way (its own objects), with the same obstacles made afresh by the test, and,
for the sanctioned edit, the same edit made by hand on that reference's geometry.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions

AWAY = pin.SE3(np.eye(3), np.array([2.0, 0.0, 0.5]))  # far enough from the panda


def _cube_mesh() -> coal.BVHModelOBBRSS:
    """A 0.2 m cube as a BVH model."""
    mesh = coal.BVHModelOBBRSS()
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1)]
    faces += [(2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    mesh.beginModel(len(faces), len(corners))
    mesh.addVertices(corners)
    for a, b, c in faces:
        mesh.addTriangle(corners[a], corners[b], corners[c])
    mesh.endModel()
    return mesh


def _grow_mesh(mesh: Any) -> None:
    mesh.beginReplaceModel()
    for k in range(mesh.num_vertices):
        # onto the panda's base (a mesh is a surface: growing it around the arm is no contact)
        mesh.replaceVertex(np.asarray(mesh.vertex(k)) * 3.0 + np.array([-2.0, 0.0, -0.3]))
    mesh.endReplaceModel(True, True)  # refit the bounding volumes


def _convex() -> Any:
    mesh = _cube_mesh()
    mesh.buildConvexHull(True, "Qt")
    return mesh.convex


def _grow_convex(convex: Any) -> None:
    points = convex.points()
    points *= 40.0  # a view: the polytope itself grows


def _octree() -> Any:
    # occupied cells over the whole workspace, but not counted as occupied above 0.99
    grid = np.linspace(-1.0, 1.0, 21)
    points = np.stack(np.meshgrid(grid, grid, grid), -1).reshape(-1, 3)
    octree = coal.makeOctree(points, 0.1)
    octree.setOccupancyThres(0.99)
    return octree


def _grow_halfspace(shape: Any) -> None:
    shape.d = 3.0


# name -> (a shape free of the panda at its placement, its placement, an in-place edit that
# makes it engulf the panda)
SHAPES: dict[str, tuple[Callable[[], Any], pin.SE3, Callable[[Any], None]]] = {
    "Box": (lambda: coal.Box(0.2, 0.2, 0.2), AWAY, lambda s: s.halfSide.__setitem__(..., 3.0)),
    "Sphere": (lambda: coal.Sphere(0.1), AWAY, lambda s: setattr(s, "radius", 3.0)),
    "Capsule": (lambda: coal.Capsule(0.1, 0.2), AWAY, lambda s: setattr(s, "radius", 3.0)),
    "Cylinder": (
        lambda: coal.Cylinder(0.1, 0.2),
        AWAY,
        lambda s: (setattr(s, "radius", 3.0), setattr(s, "halfLength", 3.0)),
    ),
    "Cone": (
        lambda: coal.Cone(0.1, 0.2),
        AWAY,
        lambda s: (setattr(s, "radius", 6.0), setattr(s, "halfLength", 6.0)),
    ),
    "Ellipsoid": (
        lambda: coal.Ellipsoid(0.1, 0.1, 0.1),
        AWAY,
        lambda s: s.radii.__setitem__(..., 3.0),
    ),
    "Halfspace": (
        lambda: coal.Halfspace(np.array([0.0, 0.0, 1.0]), -3.0),
        pin.SE3.Identity(),
        _grow_halfspace,
    ),
    "BVHModel": (_cube_mesh, AWAY, _grow_mesh),
    "Convex": (_convex, AWAY, _grow_convex),
    "HeightField": (
        lambda: coal.HeightFieldOBBRSS(4.0, 4.0, np.zeros((5, 5)), -0.1),
        pin.SE3(np.eye(3), np.array([0.0, 0.0, -3.0])),
        lambda s: s.updateHeights(np.full((5, 5), 6.0)),
    ),
    "OcTree": (_octree, pin.SE3.Identity(), lambda s: s.setOccupancyThres(0.5)),
}


_LOADED: list[Robot] = []


def _panda() -> Robot:
    """A panda of its own with convex collision shapes (Convex and Box).

    Loaded once (pairs pruned on load), then each test's robot is made from copies of its
    models (``Robot(...)`` makes its own objects from them).
    """
    if not _LOADED:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _LOADED.append(Robot.load("panda", geometry=True, convex_collision=True))
    base = _LOADED[0]
    return Robot(
        base.model,
        base.collision_model,
        base.visual_model,
        name="panda",
        default_configuration=base.q_default,
    )


def _collisions(robot_or_model: Any, geom: pin.GeometryModel, q: np.ndarray) -> np.ndarray:
    """Pinocchio's per-pair collision answers."""
    model = robot_or_model
    data, gdata = model.createData(), geom.createData()
    pin.computeCollisions(model, data, geom, gdata, q, False)
    return np.array([r.isCollision() for r in gdata.collisionResults])


def _distances(model: pin.Model, geom: pin.GeometryModel, q: np.ndarray, pairs: list[int]) -> Any:
    data, gdata = model.createData(), geom.createData()
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    return np.array([pin.computeDistance(geom, gdata, k).min_distance for k in pairs])


def _with_obstacles(robot: Robot) -> None:
    for name, (make, placement, _) in SHAPES.items():
        robot.add_obstacle(Obstacle(name, make(), placement))


def _answers(robot: Robot, checkers: list[CollisionChecker], q: np.ndarray) -> list[bool]:
    out = [robot.is_collision_free(q)]
    out += [bool(c.is_valid(q)) and bool(c.are_valid(q[None])[0]) for c in checkers]
    return out


def _checkers(robot: Robot) -> list[CollisionChecker]:
    return [
        CollisionChecker(robot, CollisionCheckerOptions(native=native)) for native in (False, True)
    ]


@pytest.fixture(scope="module")
def reference() -> Robot:
    """The untouched reference: loaded the same way (its own objects), obstacles made afresh."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("panda", geometry=True, convex_collision=True)
    _with_obstacles(robot)
    return robot


def _distance_pairs(robot: Robot) -> list[int]:
    """Robot-robot and robot-primitive pairs (coal has no distance to heightfields, octrees)."""
    geom = robot._collision_model
    skip = {geom.getGeometryId(n) for n in ("HeightField", "OcTree", "Halfspace")}
    return [
        k for k, p in enumerate(geom.collisionPairs) if p.first not in skip and p.second not in skip
    ]


@pytest.mark.parametrize("kind", list(SHAPES))
def test_a_shape_of_the_public_copy_modified_in_place_does_not_reach_the_robot(
    kind: str, reference: Robot
) -> None:
    robot = _panda()
    _with_obstacles(robot)
    q = robot.q_default.copy()
    checkers = _checkers(robot)  # built before the edit: their copies of the geometry
    version, world_version = robot.version, robot.world.version
    ref_model, ref_geom = reference._model, reference._collision_model
    expected = _collisions(ref_model, ref_geom, q)
    assert not expected.any()  # every shape starts clear of the panda
    assert _answers(robot, checkers, q) == [True, True, True]

    copy = robot.collision_model
    shape = copy.geometryObjects[copy.getGeometryId(kind)].geometry
    SHAPES[kind][2](shape)
    # the edit is a real one: the copy now collides (what the robot would say if it shared)
    assert _collisions(robot.model, copy, q).any()

    # the robot, its own geometry, checkers made before and after: as the reference
    assert _answers(robot, checkers, q) == [True, True, True]
    assert _answers(robot, _checkers(robot), q) == [True, True, True]
    assert np.array_equal(_collisions(robot._model, robot._collision_model, q), expected)
    pairs = _distance_pairs(reference)
    assert np.allclose(
        _distances(robot._model, robot._collision_model, q, pairs),
        _distances(ref_model, ref_geom, q, pairs),
        rtol=0,
        atol=1e-12,
    )
    assert (robot.version, robot.world.version) == (version, world_version)


def test_a_robot_shape_of_the_public_copy_modified_in_place_does_not_reach_the_robot(
    reference: Robot,
) -> None:
    robot = _panda()
    _with_obstacles(robot)
    rng = np.random.default_rng(3)
    qs = [robot.random_configuration(rng) for _ in range(20)] + [robot.q_default]
    checkers = _checkers(robot)
    expected = [_collisions(reference._model, reference._collision_model, q) for q in qs]
    copy = robot.collision_model
    for k in range(robot.robot_geometry_count):  # every link: Convex (and Box) shapes
        shape = copy.geometryObjects[k].geometry
        if isinstance(shape, coal.ConvexBase):
            _grow_convex(shape)
        else:
            shape.halfSide[:] = 1.0
    assert not np.array_equal(_collisions(robot.model, copy, qs[0]), expected[0])
    for q, want in zip(qs, expected):
        assert np.array_equal(_collisions(robot._model, robot._collision_model, q), want)
        assert _answers(robot, checkers, q) == [not want.any()] * 3


def test_the_next_copy_shows_the_robot_shapes_again() -> None:
    robot = _panda()
    _with_obstacles(robot)
    gid = robot.collision_model.getGeometryId("BVHModel")
    first = robot.collision_model
    mesh_before = np.asarray(first.geometryObjects[gid].geometry.vertices()).copy()
    _grow_mesh(first.geometryObjects[gid].geometry)
    first.geometryObjects[0].geometry.points()[:] *= 2.0
    robot.disable_collision_pairs([robot.collision_pairs[0]])  # a change: the copy is renewed
    second = robot.collision_model
    assert second is not first
    assert np.array_equal(second.geometryObjects[gid].geometry.vertices(), mesh_before)
    for k in range(second.ngeoms):  # equal, by content, to the robot's own shapes
        assert (
            second.geometryObjects[k].geometry == robot._collision_model.geometryObjects[k].geometry
        )
    # the kept mesh clone is handed out again (no new clone) while it equals the robot's
    held = second.geometryObjects[gid].geometry
    robot.disable_collision_pairs([robot.collision_pairs[0]])
    third = robot.collision_model
    assert third is not second
    assert (
        third.geometryObjects[gid].geometry == robot._collision_model.geometryObjects[gid].geometry
    )
    _grow_mesh(held)  # modified after it was handed out again: the next copy clones anew
    robot.disable_collision_pairs([robot.collision_pairs[0]])
    fourth = robot.collision_model
    assert np.array_equal(fourth.geometryObjects[gid].geometry.vertices(), mesh_before)


def test_an_obstacle_shape_modified_in_place_after_add_obstacle_does_not_reach_the_robot(
    reference: Robot,
) -> None:
    robot = _panda()
    shapes = {}
    for name, (make, placement, _) in SHAPES.items():
        shapes[name] = make()
        robot.add_obstacle(Obstacle(name, shapes[name], placement))
    q = robot.q_default.copy()
    checkers = _checkers(robot)
    for name, shape in shapes.items():
        SHAPES[name][2](shape)
    assert _answers(robot, checkers, q) == [True, True, True]
    assert not _collisions(robot._model, robot._collision_model, q).any()
    pairs = _distance_pairs(reference)
    assert np.allclose(
        _distances(robot._model, robot._collision_model, q, pairs),
        _distances(reference._model, reference._collision_model, q, pairs),
        rtol=0,
        atol=1e-12,
    )


def test_a_robot_made_from_models_does_not_share_their_shapes() -> None:
    source = _panda()
    model, geom = source.model.copy(), source.collision_model.copy()
    robot = Robot(
        model, geom, source.visual_model, name="copy", default_configuration=source.q_default
    )
    q = source.q_default
    before = _collisions(robot._model, robot._collision_model, q)
    for k in range(geom.ngeoms):
        shape = geom.geometryObjects[k].geometry
        if isinstance(shape, coal.ConvexBase):
            _grow_convex(shape)
    assert not np.array_equal(_collisions(model, geom, q), before)
    assert np.array_equal(_collisions(robot._model, robot._collision_model, q), before)
    assert robot.is_collision_free(q) == (not before.any())


# ---------------------------------------------------------------------- the sanctioned route
def test_an_in_place_edit_in_edit_collision_model_reaches_the_robot_and_bumps_the_version(
    reference: Robot,
) -> None:
    robot = _panda()
    _with_obstacles(robot)
    q = robot.q_default.copy()
    checkers = _checkers(robot)
    world_version = robot.world.version
    link = robot._collision_model.geometryObjects[3].name
    with robot.edit_collision_model() as geom:
        held = geom.geometryObjects[geom.getGeometryId(link)].geometry
        _grow_convex(held)
    assert robot.world.version != world_version
    # the reference: the same edit by hand on a clone in the reference's geometry
    ref_geom = reference._collision_model.copy()
    ref_obj = ref_geom.geometryObjects[ref_geom.getGeometryId(link)]
    grown = ref_obj.geometry.clone()
    _grow_convex(grown)
    ref_obj.geometry = grown
    expected = _collisions(reference._model, ref_geom, q)
    assert expected.any()  # the grown link hits something
    assert np.array_equal(_collisions(robot._model, robot._collision_model, q), expected)
    assert _answers(robot, checkers, q) == [False, False, False]
    # the shape the block handed out is not the robot's: modifying it later changes nothing
    _grow_convex(held)
    assert np.array_equal(_collisions(robot._model, robot._collision_model, q), expected)
    pairs = [k for k in _distance_pairs(reference)]
    assert np.allclose(
        _distances(robot._model, robot._collision_model, q, pairs),
        _distances(reference._model, ref_geom, q, pairs),
        rtol=0,
        atol=1e-12,
    )


def test_an_edit_collision_model_block_that_raises_leaves_the_shapes_unchanged(
    reference: Robot,
) -> None:
    robot = _panda()
    _with_obstacles(robot)
    q = robot.q_default.copy()
    world_version = robot.world.version
    with pytest.raises(RuntimeError, match="abandoned"):
        with robot.edit_collision_model() as geom:
            for k in range(robot.robot_geometry_count):
                shape = geom.geometryObjects[k].geometry
                if isinstance(shape, coal.ConvexBase):
                    _grow_convex(shape)
            raise RuntimeError("abandoned")
    assert robot.world.version == world_version
    assert np.array_equal(
        _collisions(robot._model, robot._collision_model, q),
        _collisions(reference._model, reference._collision_model, q),
    )
    assert robot.is_collision_free(q)


def test_an_obstacle_shape_modified_in_edit_collision_model_is_refused() -> None:
    robot = _panda()
    _with_obstacles(robot)
    q = robot.q_default.copy()
    with pytest.raises(InvalidInputError, match="obstacle 'Sphere' changed"):
        with robot.edit_collision_model() as geom:
            geom.geometryObjects[geom.getGeometryId("Sphere")].geometry.radius = 3.0
    assert robot.is_collision_free(q)
