"""Checkers, spaces and compiled checkers follow the robot's world (issue #15, stale world).

The reference for "in collision" is Pinocchio's own ``computeCollisions`` on the robot's
current collision model with fresh data, independent of any cached checker state. The world
is changed so that the counts stay the same (clear one obstacle, add another one), which is
what a count comparison cannot see.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot, World
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

CHECKERS = {
    "compiled": CollisionCheckerOptions(native=True),
    "pool": CollisionCheckerOptions(native=False),
    "no_broadphase": CollisionCheckerOptions(broadphase=False, native=False),
}


def _collides(robot: Robot, q: np.ndarray) -> bool:
    """Independent reference: Pinocchio on the robot's current models, fresh data."""
    data = robot.model.createData()
    gdata = robot.collision_model.createData()
    return bool(pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True))


def _swept_plate(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray, Obstacle]:
    """Two poses of the base joint and a thin plate across the arc the hand sweeps between."""
    q0 = robot.q_default.copy()
    q1 = q0.copy()
    q1[0] += 1.2
    qm = q0.copy()
    qm[0] += 0.6
    hand_mid = robot.frame_placement(qm, "panda_hand_tcp").translation
    yaw = float(np.arctan2(hand_mid[1], hand_mid[0]))
    plate = Obstacle.box("plate", [0.3, 0.005, 0.3], pin.SE3(pin.utils.rotate("z", yaw), hand_mid))
    return q0, q1, qm, plate


@pytest.fixture
def robot() -> Robot:
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("far", 0.05, [-1.5, -1.5, 2.0]))  # touches nothing
    return robot


@pytest.mark.parametrize("kind", list(CHECKERS))
def test_checker_follows_clear_and_add_with_same_counts(robot: Robot, kind: str) -> None:
    q0, _, qm, plate = _swept_plate(robot)
    checker = CollisionChecker(robot, CHECKERS[kind])
    assert checker.is_valid(qm)  # the old world: nothing in the arc
    ngeoms, npairs = robot.collision_model.ngeoms, len(robot.collision_model.collisionPairs)
    robot.clear_obstacles()
    robot.add_obstacle(plate)
    assert robot.collision_model.ngeoms == ngeoms  # the counts did not change
    assert len(robot.collision_model.collisionPairs) == npairs
    assert _collides(robot, qm)
    assert not checker.is_valid(qm)
    assert not checker.are_valid(qm[None])[0]
    assert checker.first_invalid(np.vstack([q0, qm])) == 1
    assert any("plate" in pair for pair in checker.colliding_pairs(qm))
    assert checker.world_version == robot.world.version


def test_compiled_handle_is_rebuilt_on_the_new_world(robot: Robot) -> None:
    _, _, qm, plate = _swept_plate(robot)
    checker = CollisionChecker(robot)
    old = checker.native_kernel()
    if old is None:
        pytest.skip("compiled planning kernel not built")
    assert old.first_invalid(qm[None]) < 0
    robot.clear_obstacles()
    robot.add_obstacle(plate)
    new = checker.native_kernel()
    assert new is not old
    assert new.first_invalid(qm[None]) == 0


@pytest.mark.parametrize("native", [True, False])
def test_space_and_rrt_connect_avoid_the_new_obstacle(robot: Robot, native: bool) -> None:
    q0, q1, _, plate = _swept_plate(robot)
    space = ConfigurationSpace.from_robot(
        robot,
        edge=EdgeCheckOptions(resolution=0.01),
        checker_options=CollisionCheckerOptions(native=native),
    )
    assert space.motion_valid(q0, q1)  # in the old world the straight line is free
    robot.clear_obstacles()
    robot.add_obstacle(plate)
    result = rrt_connect(
        space, q0, q1, RRTConnectOptions(native=native, max_iterations=3000, seed=3)
    )
    if result.success:  # any returned path must be free in the new world
        path = result.path
        dense = [
            a + t * (b - a)
            for a, b in itertools.pairwise(path)
            for t in np.linspace(0.0, 1.0, 1 + int(np.ceil(np.linalg.norm(b - a) / 0.01)))
        ]
        assert not any(_collides(robot, q) for q in dense)
    assert not space.motion_valid(q0, q1)
    assert space.world_version == robot.world.version


def test_world_version_changes_on_every_mutation() -> None:
    world = World()
    seen = {world.version}
    box = Obstacle.box("b", [0.1, 0.1, 0.1])
    for change in (
        lambda: world.add(box),
        lambda: world.remove("b"),
        lambda: world.add(box),
        world.clear,
        world.mark_changed,
    ):
        change()
        assert world.version not in seen  # never reused, also after add-remove-add
        seen.add(world.version)
    assert World().version not in seen  # nor across worlds


def test_obstacle_is_an_immutable_value() -> None:
    box = Obstacle.box("b", [0.1, 0.1, 0.1])
    with pytest.raises(dataclasses.FrozenInstanceError):
        box.placement = pin.SE3.Identity()  # type: ignore[misc]


def test_state_distances_follow_the_new_world(robot: Robot) -> None:
    _, _, qm, plate = _swept_plate(robot)
    state = robot.state(qm)
    state.compute_distances()
    robot.clear_obstacles()
    robot.add_obstacle(plate)
    state.update(qm)
    names = robot.collision_pairs
    dists = [r.min_distance for r in state.distance_results()]
    assert len(dists) == len(names)
    plate_pairs = [d for d, pair in zip(dists, names) if "plate" in pair]
    assert min(plate_pairs) < 0.0  # penetration: the hand is in the plate
