"""The checker's in-memory sphere model across scenes (``CollisionChecker.sphere_model``).

A scene's set-up makes a new checker; the robot's spheres are kept per robot and reused while
the robot's moving geometries (names, joints, placements, shapes) are unchanged: obstacles
added or removed do not change them, an in-place change of a moving geometry does. Reference:
:func:`~taskspace.planning.sphere_model.sphere_model` of the robot's current collision model
on its moving geometries (the definition of the spheres), and the spheres placed by hand.
(An in-place edit of ``robot._collision_model`` is not the robot's API; the checker follows it
all the same.)
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.sphere_model import SphereModel, sphere_model


def _moving(robot: Robot) -> list[int]:
    objs = robot._collision_model.geometryObjects
    return [i for i in range(robot._collision_model.ngeoms) if objs[i].parentJoint != 0]


def _same(a: SphereModel, b: SphereModel) -> bool:
    return (
        np.array_equal(a.centers, b.centers)
        and np.array_equal(a.radii, b.radii)
        and np.array_equal(a.joints, b.joints)
        and np.array_equal(a.geometries, b.geometries)
    )


def test_obstacles_keep_the_spheres_and_moving_geometries_change_them() -> None:
    robot = Robot.load("panda", convex_collision=True)
    first = CollisionChecker(robot).sphere_model()
    assert _same(first, sphere_model(robot._collision_model, _moving(robot)))
    assert not np.isin(first.geometries, np.arange(robot.robot_geometry_count, 100)).any()

    # a scene: obstacles added (they are on the universe: no spheres), a new checker
    robot.add_obstacle(Obstacle.box("table", [1.0, 1.0, 0.1], (0.5, 0.0, -0.1)))
    robot.add_obstacle(Obstacle.sphere("ball", 0.1, (0.4, 0.3, 0.5)))
    second = CollisionChecker(robot).sphere_model()
    assert second is first  # the same spheres, not fitted or loaded again

    # a moving geometry moved in place (not through the robot's methods): new spheres, placed
    objs = robot._collision_model.geometryObjects
    i = _moving(robot)[2]
    shift = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.05]))
    old = pin.SE3(objs[i].placement)
    objs[i].placement = old * shift
    moved = CollisionChecker(robot).sphere_model()
    assert moved is not first
    assert _same(moved, sphere_model(robot._collision_model, _moving(robot)))
    rows = first.geometries == i
    assert rows.any()
    # in the joint frame: placement * centre, the placement now old * shift
    expected = first.centers[rows] + old.rotation @ shift.translation
    np.testing.assert_allclose(moved.centers[rows], expected, atol=1e-12)
    np.testing.assert_array_equal(moved.centers[~rows], first.centers[~rows])

    # renamed in place: new key
    objs[i].placement = old
    back = CollisionChecker(robot).sphere_model()
    assert back is not moved
    np.testing.assert_allclose(back.centers, first.centers, atol=1e-12)
    np.testing.assert_array_equal(back.radii, first.radii)
    name = objs[i].name
    objs[i].name = name + "_renamed"
    renamed = CollisionChecker(robot).sphere_model()
    assert renamed is not back
    assert _same(renamed, sphere_model(robot._collision_model, _moving(robot)))
    objs[i].name = name


def test_a_kernel_of_a_later_scene_gets_the_spheres() -> None:
    """The sphere kernel of a scene built after another one carries the cached spheres."""
    robot = Robot.load("panda", convex_collision=True)
    CollisionChecker(robot).sphere_kernel()
    robot.add_obstacle(Obstacle.box("wall", [0.1, 1.0, 1.0], (0.6, 0.0, 0.5)))
    checker = CollisionChecker(robot)
    kernel = checker.sphere_kernel()
    assert kernel is not None and kernel.has_spheres
    reference = sphere_model(robot._collision_model, _moving(robot))
    assert kernel.sphere_count == reference.radii.size


def test_an_in_place_move_without_a_scene_change_is_seen() -> None:
    """No obstacle in between (the model's vector of objects stays where it is): the cached
    key must hold its own copy of each placement, not the object's (which the edit changes)."""
    robot = Robot.load("panda", convex_collision=True)
    first = CollisionChecker(robot).sphere_model()
    objs = robot._collision_model.geometryObjects
    i = _moving(robot)[4]
    objs[i].placement = pin.SE3(objs[i].placement) * pin.SE3(np.eye(3), np.array([0.02, 0, 0]))
    moved = CollisionChecker(robot).sphere_model()
    assert moved is not first
    assert _same(moved, sphere_model(robot._collision_model, _moving(robot)))
