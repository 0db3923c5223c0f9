"""RRT* to "any Feature within bounds": the Panda's hand in a box, goals sampled by IK.

The reached goal is checked with Pinocchio's forward kinematics on the model, independent
of the features and the IK that sampled it.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.errors import InvalidInputError
from taskspace.ik import FeatureGoalRegion
from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.rrt_star import GoalRegion, RRTStarOptions, rrt_star

FRAME = "panda_hand_tcp"


def hand_position(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Pinocchio FK of the tool frame (no taskspace feature involved)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return np.array(data.oMf[robot.model.getFrameId(FRAME)].translation)


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda", convex_collision=True)


def test_panda_hand_reaches_a_box_around_an_obstacle() -> None:
    robot = Robot.load("panda", convex_collision=True)
    start = robot.q_default
    here = hand_position(robot, start)
    block = here + np.array([0.0, 0.15, 0.0])  # halfway along the hand's straight move
    robot.add_obstacle(Obstacle.box("block", [0.08, 0.04, 0.08], block))
    space = ConfigurationSpace.from_robot(robot)
    centre = here + np.array([0.0, 0.3, 0.0])
    # x and y within 2 cm of the centre, z only bounded below (a half-open side)
    lower = centre - [0.02, 0.02, 0.03]
    upper = np.array([centre[0] + 0.02, centre[1] + 0.02, np.inf])
    region = FeatureGoalRegion(F.Position(robot, FRAME), lower, upper)
    assert isinstance(region, GoalRegion)
    assert not region.contains(start)
    opts = RRTStarOptions(max_iterations=400, time_limit_s=None, goal_bias=0.2, seed=2)
    result = rrt_star(space, start, region, opts)
    assert result.success
    assert result.log["first_solution_by"] == "rrt_connect"  # to an IK sample of the region
    end_position = hand_position(robot, result.path[-1])
    assert np.all(end_position >= lower) and np.all(end_position <= upper)
    assert space.path_valid(result.path)
    np.testing.assert_array_equal(result.path[0], start)


def test_contains_and_samples_agree_with_forward_kinematics(panda: Robot) -> None:
    centre = np.array([0.4, 0.0, 0.4])
    half = np.array([0.25, 0.25, 0.2])
    lower, upper = centre - half, centre + half
    region = FeatureGoalRegion(F.Position(panda, FRAME), lower, upper)
    rng = np.random.default_rng(0)
    inside = 0
    for _ in range(300):  # random configurations: membership by FK equals contains
        q = panda.random_configuration(rng)
        p = hand_position(panda, q)
        expected = bool(np.all(p >= lower) and np.all(p <= upper))
        inside += expected
        assert region.contains(q) == expected
    assert 0 < inside < 300
    samples = [region.sample(rng) for _ in range(5)]
    assert sum(s is not None for s in samples) >= 4
    for q in samples:
        if q is None:
            continue
        p = hand_position(panda, q)
        assert np.all(p >= lower) and np.all(p <= upper)
        assert region.contains(q)
        assert np.all(q >= panda.model.lowerPositionLimit)
        assert np.all(q <= panda.model.upperPositionLimit)
    # the samples spread over the box (targets drawn in it), not all at one point
    spread = np.ptp([hand_position(panda, q) for q in samples if q is not None], axis=0)
    assert np.all(spread > 1e-3)


def test_bad_regions_are_refused(panda: Robot) -> None:
    position = F.Position(panda, FRAME)
    with pytest.raises(InvalidInputError, match="PoseGoalRegion"):
        FeatureGoalRegion(F.FramePose(panda, FRAME), -1.0, 1.0)
    with pytest.raises(InvalidInputError, match="size 3"):
        FeatureGoalRegion(position, [0, 0], [1, 1])
    with pytest.raises(InvalidInputError, match="lower <= upper"):
        FeatureGoalRegion(position, 1.0, 0.0)
    with pytest.raises(InvalidInputError, match="lower <= upper"):
        FeatureGoalRegion(position, np.nan, 0.0)
    with pytest.raises(InvalidInputError, match="Feature"):
        FeatureGoalRegion("hand", 0.0, 1.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="Generator"):
        FeatureGoalRegion(position, -1.0, 1.0).sample(0)  # type: ignore[arg-type]
