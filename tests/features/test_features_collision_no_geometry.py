"""Collision distances and avoidance on a robot without collision geometry are refused.

Before, ``CollisionAvoidance(Robot.load("panda", geometry=False))`` was accepted and added no
row at any step: an IK stack "avoiding collisions" that avoided nothing (audit5 left it open).
"""

from __future__ import annotations

import pytest

from taskspace.constraints import CollisionAvoidance
from taskspace.errors import InvalidInputError
from taskspace.features import CollisionDistance
from taskspace.model import Robot


def test_no_geometry_is_refused() -> None:
    robot = Robot.load("panda", geometry=False)
    assert robot.robot_geometry_count == 0
    with pytest.raises(InvalidInputError, match="no collision geometry"):
        CollisionDistance(robot)
    with pytest.raises(InvalidInputError, match="no collision geometry"):
        CollisionAvoidance(robot)


def test_with_geometry_still_accepted() -> None:
    robot = Robot.load("panda")
    assert CollisionDistance(robot).dim == len(robot.collision_pairs) > 0


def test_from_urdf_names_a_bad_path() -> None:
    with pytest.raises(InvalidInputError, match="URDF file path"):
        Robot.from_urdf(None)  # type: ignore[arg-type]
