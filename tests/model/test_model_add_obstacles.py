"""Robot.add_obstacles makes the collision data once; it always matches the collision model.

Reference: Pinocchio's ``computeCollisions`` on every pair with a fresh ``GeometryData``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot


def at(x: float, y: float, z: float) -> pin.SE3:
    """A placement at (x, y, z) [m], no rotation."""
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def _reference(robot: Robot, q: np.ndarray) -> bool:
    model, geom = robot._model, robot._collision_model
    return not pin.computeCollisions(model, model.createData(), geom, geom.createData(), q, True)


def test_add_obstacles_matches_one_by_one_and_pinocchio() -> None:
    obstacles = [
        Obstacle.box("front", [0.2, 1.0, 1.0], at(0.5, 0, 0.5)),
        Obstacle.sphere("top", 0.15, at(0.1, -0.3, 0.9)),
        Obstacle.box("left", [1.0, 0.2, 1.0], at(0, 0.45, 0.4)),
    ]
    batch = Robot.load("panda", convex_collision=True)
    batch.add_obstacles(obstacles)
    single = Robot.load("panda", convex_collision=True)
    for obstacle in obstacles:
        single.add_obstacle(obstacle)
    assert [p for p in batch.collision_pairs] == [p for p in single.collision_pairs]
    rng = np.random.default_rng(5)
    lo, hi = batch.model.lowerPositionLimit, batch.model.upperPositionLimit
    answers = []
    for q in rng.uniform(lo, hi, (60, batch.nq)):
        expected = _reference(batch, q)
        assert batch.is_collision_free(q) == single.is_collision_free(q) == expected
        answers.append(expected)
    assert any(answers) and not all(answers)


def test_an_invalid_obstacle_keeps_the_earlier_ones_and_a_matching_data() -> None:
    robot = Robot.load("panda", convex_collision=True)
    a = Obstacle.box("a", [0.2, 1.0, 1.0], at(0.5, 0, 0.5))
    b = Obstacle.sphere("b", 0.15, at(0.1, -0.3, 0.9))
    with pytest.raises(InvalidInputError, match="already exists"):
        robot.add_obstacles([a, b, a, Obstacle.sphere("c", 0.1, at(0, 0, 2))])
    assert [o.name for o in robot.world] == ["a", "b"]
    geom = robot._collision_model
    assert len(robot.collision_data.oMg) == geom.ngeoms
    assert len(robot.collision_data.collisionResults) == len(geom.collisionPairs)
    q = robot.q_default.copy()
    q[0] = 0.0
    assert robot.is_collision_free(q) == _reference(robot, q)


def test_collision_data_is_made_at_first_use_and_new_after_every_change() -> None:
    # the robot's own GeometryData (about 2 us per pair to make) is made when a query needs
    # it, not at each obstacle change; every change of the collision model gives a new one
    robot = Robot.load("panda", convex_collision=True)
    q = robot.q_default.copy()
    first = robot.collision_data
    assert robot.collision_data is first  # no change: the same data
    seen = [first]

    def fresh_and_right() -> None:
        data = robot.collision_data
        assert all(data is not old for old in seen)
        seen.append(data)
        geom = robot._collision_model
        assert len(data.oMg) == geom.ngeoms
        assert len(data.collisionResults) == len(geom.collisionPairs)
        for x in (0.3, 0.6):
            q[0] = x
            assert robot.is_collision_free(q) == _reference(robot, q)

    robot.add_obstacles([Obstacle.box("wall", [0.2, 1.0, 1.0], at(0.45, 0, 0.5))])
    fresh_and_right()
    robot.add_obstacle(Obstacle.sphere("ball", 0.1, at(0.0, 0.4, 0.6)))
    fresh_and_right()
    robot.remove_obstacle("wall")
    fresh_and_right()
    robot.disable_collision_pairs([robot.collision_pairs[0]])
    fresh_and_right()
    robot.clear_obstacles()
    fresh_and_right()
    # a query after a change without reading collision_data first
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 1.0], at(0.45, 0, 0.5)))
    q[0] = 0.0
    assert robot.is_collision_free(q) == _reference(robot, q)
    assert bool(robot.colliding_pairs(q)) == (not _reference(robot, q))
