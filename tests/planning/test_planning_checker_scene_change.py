"""A scene change builds only what the next queries use, and every query answers for the new scene.

``CollisionChecker`` keeps Pinocchio's broad-phase pool and data for its Python-side queries
and the compiled checker for the others; a world change drops them and each is built again at
the first query that needs it. Reference: Pinocchio's ``computeCollisions`` on every pair
with a fresh ``GeometryData`` of the robot's current models (nothing cached, no broad phase).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import planning_kernel
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from tests.planning._planning_worlds import pinocchio_collision_flags

OPTIONS = {
    "kernel": CollisionCheckerOptions(),
    "broadphase_pool": CollisionCheckerOptions(native=False),
    "geometry_pool": CollisionCheckerOptions(native=False, broadphase=False),
}


@pytest.fixture(scope="module")
def robot_and_configurations() -> tuple[Robot, np.ndarray]:
    robot = Robot.load("panda", convex_collision=True)
    rng = np.random.default_rng(3)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    return robot, rng.uniform(lo, hi, (150, robot.nq))


def at(x: float, y: float, z: float) -> pin.SE3:
    """A placement at (x, y, z) [m], no rotation."""
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def _scene(robot: Robot, which: int) -> None:
    """Two obstacle sets that collide with different configurations."""
    robot.clear_obstacles()
    if which == 0:
        robot.add_obstacle(Obstacle.box("front", [0.2, 1.0, 1.0], at(0.5, 0, 0.5)))
    else:
        robot.add_obstacle(Obstacle.box("left", [1.0, 0.2, 1.0], at(0, 0.45, 0.4)))
        robot.add_obstacle(Obstacle.sphere("top", 0.15, at(0.1, -0.3, 0.9)))


@pytest.mark.parametrize("name", list(OPTIONS))
def test_answers_follow_scene_changes(name: str, robot_and_configurations: Any) -> None:
    robot, qs = robot_and_configurations
    _scene(robot, 0)
    checker = CollisionChecker(robot, OPTIONS[name])
    seen = []
    for which in (0, 1, 0):  # queries, then a scene change, then queries again
        _scene(robot, which)
        expected = pinocchio_collision_flags(robot, qs)
        seen.append(expected)
        assert np.array_equal(~checker.are_valid(qs), expected)
        assert [checker.is_valid(q) for q in qs[:20]] == (~expected[:20]).tolist()
        first = int(np.flatnonzero(expected)[0])
        assert checker.first_invalid(qs) == first
    assert not np.array_equal(seen[0], seen[1])  # the scenes differ where it is checked


def test_a_scene_change_builds_no_python_side_structures_for_the_compiled_checker(
    robot_and_configurations: Any,
) -> None:
    if planning_kernel() is None:
        pytest.skip("the compiled planning kernel is not built")
    robot, qs = robot_and_configurations
    _scene(robot, 0)
    checker = CollisionChecker(robot)
    checker.are_valid(qs[:10])
    _scene(robot, 1)
    assert np.array_equal(~checker.are_valid(qs), pinocchio_collision_flags(robot, qs))
    # the compiled checker answered: Pinocchio's pool and data were never built
    assert checker._pool is None and checker._geometry_pool is None
    assert checker._geom_data is None and checker._data is None
    # a Python-side query builds them, on the current scene
    pairs = checker.colliding_pairs(
        qs[int(np.flatnonzero(pinocchio_collision_flags(robot, qs))[0])]
    )
    assert pairs and checker._pool is not None and checker._geom_data is not None
