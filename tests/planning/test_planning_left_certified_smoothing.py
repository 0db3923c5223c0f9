"""A certified smooth path: the example of ``smooth_bspline``'s docstring, run as written.

B-spline smoothing checks its new segments at the space's resolution only. The docstring's
recipe certifies the smoothed path with ``certify_path`` and keeps the planner's certified
path when the proof fails. On this Panda scene (a block where the hand's straight move
passes) some of seeds 0-5 give a smoothed path that certifies, others one that does not (a cut
corner within the 1e-4 m tolerance of the block), so both branches run. The chosen path is
checked independently: Pinocchio's computeDistances every 0.002 rad along it.
"""

from __future__ import annotations

import functools
import itertools
import textwrap

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning import (
    RRTConnectOptions,
    certify_path,
    rrt_connect,
    smooth_bspline,
)
from taskspace.planning.configuration_space import ConfigurationSpace


def _example() -> str:
    """The code block of smooth_bspline's Example section."""
    doc = smooth_bspline.__doc__
    assert doc is not None
    block = doc.split("Example:", 1)[1].split("::\n\n", 1)[1]
    lines = list(itertools.takewhile(lambda line: line.strip() != "", block.splitlines()))
    return textwrap.dedent("\n".join(lines))


@pytest.fixture(scope="module")
def scene() -> tuple[Robot, ConfigurationSpace, np.ndarray, np.ndarray]:
    robot = Robot.load("panda", convex_collision=True)
    start = robot.q_default.copy()
    goal, mid = start.copy(), start.copy()
    goal[0] += 1.5
    mid[0] += 0.75
    hand = robot.frame_placement(mid, "panda_hand_tcp").translation
    robot.add_obstacle(Obstacle.box("block", [0.1, 0.3, 0.3], hand))
    return robot, ConfigurationSpace.from_robot(robot), start, goal


def _least_distance_densely(robot: Robot, path: np.ndarray, step: float = 0.002) -> float:
    model, geometry = robot.model, robot.collision_model
    data, gdata = model.createData(), geometry.createData()
    least = np.inf
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        for t in np.linspace(0.0, 1.0, n + 1):
            pin.computeDistances(model, data, geometry, gdata, a + t * (b - a))
            least = min(least, min(r.min_distance for r in gdata.distanceResults))
    return float(least)


def test_the_docstring_recipe_returns_a_certified_path(
    scene: tuple[Robot, ConfigurationSpace, np.ndarray, np.ndarray],
) -> None:
    robot, space, start, goal = scene
    branches: list[bool] = []
    # seeds until both branches of the recipe have run (the smooth path certified, and not),
    # each seed's result checked in full
    for seed in range(40):
        if True in branches and False in branches:
            break
        names = {
            "robot": robot,
            "space": space,
            "start": start,
            "goal": goal,
            "rrt_connect": rrt_connect,
            "RRTConnectOptions": functools.partial(RRTConnectOptions, seed=seed),
            "smooth_bspline": smooth_bspline,
            "certify_path": certify_path,
        }
        exec(_example(), names)  # the docstring's code, unchanged
        result, smooth, path = names["result"], names["smooth"], names["path"]
        assert result.success and result.log["certified"] == 1.0
        smooth_certified = certify_path(robot, smooth).certified
        branches.append(smooth_certified)
        assert path is (smooth if smooth_certified else result.path)
        assert certify_path(robot, path).certified
        assert _least_distance_densely(robot, path) > 0.0
        np.testing.assert_array_equal(path[0], start)
        np.testing.assert_array_equal(path[-1], goal)
        assert space.path_length(path) <= space.path_length(result.path) + 1e-12
    assert True in branches and False in branches, branches  # both ways of the recipe ran
