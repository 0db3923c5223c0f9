"""RRT-Connect (its Python planner) given a step far longer than any line.

``step_size=1e9`` is how an OMPL user says "no step limit" (OMPL's range). The planner made
the check pattern of a full step, ``step_size / resolution`` points, before planning, though
no line in the bounds is that long: 2e10 points for 1e9 (the process was killed for its
memory). The path is checked here densely against the boxes themselves (not the planner's
checker), every 1e-3 along each edge.
"""

from __future__ import annotations

import itertools
import tracemalloc

import numpy as np
import pytest

from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from tests.planning._planning_worlds import free_densely, wall_space


@pytest.mark.parametrize(("seed", "resolution"), [(0, 0.05), (1, 0.049), (2, 0.051)])
def test_a_step_longer_than_the_bounds_plans_in_little_memory(seed: int, resolution: float) -> None:
    start, goal = [1.0, 2.0], [9.0, 2.0]  # the straight line crosses the wall
    tracemalloc.start()
    try:
        result = rrt_connect(
            wall_space(resolution=resolution),
            start,
            goal,
            RRTConnectOptions(step_size=1e4, seed=seed, time_limit_s=None, max_iterations=5000),
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # a full step's pattern would be 1e4 / 0.05 = 2e5 points (a different pattern per
    # resolution: patterns are cached) (~24 MB while it is built);
    # the longest line in the 10 x 10 box has 283
    assert peak < 8e6
    assert result.status is PlannerStatus.SOLVED
    assert np.array_equal(result.path[0], start) and np.array_equal(result.path[-1], goal)
    assert free_densely(result.path)


def test_a_huge_step_is_planned_like_one_longer_than_every_line() -> None:
    space = wall_space(resolution=0.05)
    runs = [
        rrt_connect(space, [1.0, 2.0], [9.0, 2.0], RRTConnectOptions(step_size=s, seed=4))
        for s in (1e4, 20.0)  # 20 > the box's diagonal (14.1): the same tree
    ]
    assert all(r.status is PlannerStatus.SOLVED for r in runs)
    assert np.array_equal(runs[0].path, runs[1].path)


def test_the_compiled_planner_takes_a_step_longer_than_the_bounds() -> None:
    # the kernel refused step_size=1e9 ("alpha and delta are too small": 1e9 / 0.03 checks
    # per full step); a step beyond the bounds' diameter plans as the diameter: same trees
    import pinocchio as pin

    from taskspace.model import Obstacle, Robot
    from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions

    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(
        Obstacle.box("wall", [0.1, 1.0, 0.6], pin.SE3(np.eye(3), np.r_[0.45, 0, 0.5]))
    )
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    start = robot.q_default.copy()
    goal = start.copy()
    goal[0] += 1.2
    diameter = space.bounds_diameter()[2]
    paths = []
    for step in (1e9, diameter):
        r = rrt_connect(space, start, goal, RRTConnectOptions(step_size=step, seed=3))
        assert r.success and r.log["native"] == 1.0
        paths.append(r.path)
    np.testing.assert_array_equal(paths[0], paths[1])
    reference = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(paths[0]):
        for t in np.linspace(0.0, 1.0, max(2, int(np.ceil(np.linalg.norm(b - a) / 0.01)) + 1)):
            q = a + t * (b - a)
            assert not pin.computeCollisions(
                robot.model, reference[0], robot.collision_model, reference[1], q, True
            )
