"""Collision pairs changed through the robot carry a version: checkers built before follow.

Reference: Pinocchio's ``computeCollisions`` on a geometry model holding exactly the pairs
that should be checked, built here from the geometry objects (not from the robot's model).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.model import Robot
from taskspace.planning import ConfigurationSpace


def _reference_collides(robot: Robot, pairs: list[tuple[str, str]], q: np.ndarray) -> bool:
    cm = pin.GeometryModel()
    for g in robot.collision_model.geometryObjects:
        cm.addGeometryObject(g)
    for a, b in pairs:
        cm.addCollisionPair(pin.CollisionPair(cm.getGeometryId(a), cm.getGeometryId(b)))
    return bool(
        pin.computeCollisions(robot.model, robot.model.createData(), cm, cm.createData(), q, True)
    )


@pytest.fixture(scope="module")
def ur5_self_collision() -> tuple[Robot, np.ndarray, tuple[str, str]]:
    """ur5 and a configuration where exactly one robot pair collides."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("ur5")
    rng = np.random.default_rng(0)
    for _ in range(20000):
        q = robot.random_configuration(rng)
        hits = robot.colliding_pairs(q)
        if len(hits) == 1:
            return robot, q, hits[0]
    raise AssertionError("no configuration with exactly one colliding pair")


@pytest.mark.parametrize("native", [True, False])
def test_checker_built_before_follows_disabled_and_enabled_pairs(
    ur5_self_collision: tuple[Robot, np.ndarray, tuple[str, str]], native: bool
) -> None:
    robot, q, pair = ur5_self_collision
    from taskspace.planning import CollisionCheckerOptions

    space = ConfigurationSpace.from_robot(
        robot, checker_options=CollisionCheckerOptions(native=native)
    )
    all_pairs = robot.collision_pairs
    assert _reference_collides(robot, all_pairs, q)
    assert not space.is_valid(q)
    version = robot.world.version
    robot.disable_collision_pairs([pair])
    try:
        assert robot.world.version != version
        assert pair not in robot.collision_pairs and (pair[1], pair[0]) not in robot.collision_pairs
        remaining = [p for p in all_pairs if p != pair]
        assert not _reference_collides(robot, remaining, q)
        assert space.is_valid(q)  # the space built before sees the change
        assert robot.is_collision_free(q)
    finally:
        robot.enable_collision_pairs([pair[::-1]])  # either order names the same pair
    assert sorted(robot.collision_pairs) == sorted(all_pairs)
    assert not space.is_valid(q)
    assert not robot.is_collision_free(q)


def test_bad_pairs_are_refused(
    ur5_self_collision: tuple[Robot, np.ndarray, tuple[str, str]],
) -> None:
    robot, _, pair = ur5_self_collision
    version = robot.world.version
    with pytest.raises(UnknownNameError, match="unknown robot geometry 'nope'"):
        robot.disable_collision_pairs([(pair[0], "nope")])
    with pytest.raises(InvalidInputError, match="paired with itself"):
        robot.disable_collision_pairs([(pair[0], pair[0])])
    with pytest.raises(InvalidInputError, match="each pair must be"):
        robot.disable_collision_pairs([pair[0]])
    with pytest.raises(InvalidInputError, match="list of"):
        robot.disable_collision_pairs("ab")
    assert robot.world.version == version  # nothing changed


def test_compiled_checker_sees_a_same_count_pair_swap_made_through_the_robot(
    ur5_self_collision: tuple[Robot, np.ndarray, tuple[str, str]],
) -> None:
    """A pair removed and another added in ``edit_collision_model`` (the count is unchanged).

    The same swap made on ``robot.collision_model`` (a copy) changes nothing; made through
    ``Robot.edit_collision_model`` it gives the world a new version, and the compiled checker
    (built before) answers with the new pairs.
    """
    robot, q, pair = ur5_self_collision
    from taskspace.planning import CollisionCheckerOptions

    space = ConfigurationSpace.from_robot(
        robot, checker_options=CollisionCheckerOptions(native=True)
    )
    checker = space.checker
    if checker.native_kernel() is None:
        pytest.skip("compiled checker not built")
    assert not space.is_valid(q)
    cm = robot.collision_model
    first, second = (cm.getGeometryId(n) for n in pair)
    colliding = pin.CollisionPair(min(first, second), max(first, second))
    free_pairs = [p for p in robot.collision_pairs if p != pair and p[::-1] != pair]
    unchecked = next(
        (a, b)
        for a in range(robot.robot_geometry_count)
        for b in range(a + 1, robot.robot_geometry_count)
        if not cm.existCollisionPair(pin.CollisionPair(a, b))
        and (a, b) != (colliding.first, colliding.second)
    )
    count = len(cm.collisionPairs)
    names = [cm.geometryObjects[i].name for i in unchecked]
    expected = _reference_collides(robot, [*free_pairs, (names[0], names[1])], q)

    def swap(geom: pin.GeometryModel) -> None:
        geom.removeCollisionPair(colliding)
        geom.addCollisionPair(pin.CollisionPair(*unchecked))
        assert len(geom.collisionPairs) == count

    version = robot.world.version
    swap(cm)  # on the copy: nothing changes
    assert robot.world.version == version and not space.is_valid(q)
    try:
        with robot.edit_collision_model() as geom:
            swap(geom)
        assert robot.world.version != version
        assert space.is_valid(q) == (not expected)
    finally:
        robot.disable_collision_pairs([(names[0], names[1])])
        robot.enable_collision_pairs([pair])
    assert not space.is_valid(q)
