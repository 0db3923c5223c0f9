"""A collision-distance feature follows the obstacle world (pair indices shift)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.features import CollisionDistance
from taskspace.model import Obstacle, Robot


def coal_distance(robot: Robot, q: np.ndarray, a: str, b: str) -> float:
    """The pair's distance from Pinocchio alone."""
    gm = robot.collision_model
    data, gd = robot.model.createData(), gm.createData()
    pin.computeDistances(robot.model, robot.model.createData(), gm, gd, q)
    pin.updateGeometryPlacements(robot.model, data, gm, gd, q)
    ia, ib = gm.getGeometryId(a), gm.getGeometryId(b)
    for k, pair in enumerate(gm.collisionPairs):
        if {pair.first, pair.second} == {ia, ib}:
            return float(gd.distanceResults[k].min_distance)
    raise AssertionError("pair not found")


def test_named_pairs_follow_a_rebuilt_world_and_removed_ones_raise() -> None:
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("A", 0.05, [0.5, 0.3, 0.5]))
    robot.add_obstacle(Obstacle.sphere("B", 0.05, [0.5, -0.3, 0.5]))
    feature = CollisionDistance(robot, [("panda_link7_0", "B")])
    q = robot.q_default
    before = feature.value(robot.state(q))[0]
    assert before == pytest.approx(coal_distance(robot, q, "panda_link7_0", "B"), abs=1e-9)
    robot.remove_obstacle("A")  # the indices of B's pairs shift
    after = feature.value(robot.state(q))[0]
    assert after == pytest.approx(coal_distance(robot, q, "panda_link7_0", "B"), abs=1e-9)
    assert after == pytest.approx(before, abs=1e-9)
    robot.clear_obstacles()
    robot.add_obstacle(Obstacle.sphere("C", 0.05, [0.5, 0.0, 0.9]))
    with pytest.raises(InvalidInputError, match="no longer exist"):
        feature.value(robot.state(q))
    every = CollisionDistance(robot)
    robot.add_obstacle(Obstacle.sphere("D", 0.05, [0.2, 0.0, 0.9]))
    with pytest.raises(InvalidInputError, match="build the feature"):
        every.value(robot.state(q))
