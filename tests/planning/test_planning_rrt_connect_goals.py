"""RRT-Connect to several goal configurations and to goal regions (OMPL's goal states).

References: in 2-D, an exact segment-versus-box test (Liang-Barsky) of every returned edge and
the region's membership computed here; on the Panda, Pinocchio's forward kinematics of the
last configuration and its ``computeCollisions`` along the path.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import PlanningError
from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

# a wall x in [0.45, 0.55], y in [0, 0.8] with a cup around the goal at (0.8, 0.5)
# and a closed ring around (0.15, 0.15)
BOXES = [(0.45, 0.55, 0.0, 0.8), (0.7, 0.9, 0.35, 0.4), (0.7, 0.9, 0.6, 0.65),
         (0.9, 0.95, 0.35, 0.65), (0.05, 0.25, 0.05, 0.08), (0.05, 0.25, 0.22, 0.25),
         (0.05, 0.08, 0.05, 0.25), (0.22, 0.25, 0.05, 0.25)]  # fmt: skip


def _free(q: np.ndarray) -> np.ndarray:
    inside = np.zeros(q.shape[0], bool)
    for x0, x1, y0, y1 in BOXES:
        inside |= (q[:, 0] > x0) & (q[:, 0] < x1) & (q[:, 1] > y0) & (q[:, 1] < y1)
    return ~inside


def _segment_hits_box(a: np.ndarray, b: np.ndarray, box: tuple[float, ...]) -> bool:
    """Liang-Barsky: does the open segment a-b meet the open box?"""
    t0, t1 = 0.0, 1.0
    d = b - a
    for p, q in ((-d[0], a[0] - box[0]), (d[0], box[1] - a[0]), (-d[1], a[1] - box[2]),
                 (d[1], box[3] - a[1])):  # fmt: skip
        if p == 0:
            if q <= 0:
                return False
            continue
        r = q / p
        if p < 0:
            t0 = max(t0, r)
        else:
            t1 = min(t1, r)
    return t1 - t0 > 1e-9


def _space() -> ConfigurationSpace:
    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(_free), edge=EdgeCheckOptions(resolution=0.002)
    )


def _exactly_free(path: np.ndarray) -> bool:
    shrunk = [(x0 + 0.002, x1 - 0.002, y0 + 0.002, y1 - 0.002) for x0, x1, y0, y1 in BOXES]
    return not any(
        _segment_hits_box(a, b, box) for a, b in itertools.pairwise(path) for box in shrunk
    )


def test_several_goals_end_at_a_reachable_one() -> None:
    space = _space()
    start = np.array([0.1, 0.5])
    walled = np.array([0.8, 0.5])  # nearest, inside the cup (open to the left)
    open_goal = np.array([0.2, 0.95])
    blocked = np.array([0.5, 0.5])  # refused: inside the wall
    with pytest.raises(PlanningError, match=r"goal\[1\] is in collision"):
        rrt_connect(space, start, np.stack([walled, blocked]))
    res = rrt_connect(space, start, np.stack([walled, open_goal]), RRTConnectOptions(seed=0))
    assert res.success and res.log["goal_states"] == 2.0
    np.testing.assert_array_equal(res.path[0], start)
    assert any(np.array_equal(res.path[-1], g) for g in (walled, open_goal))
    assert _exactly_free(res.path)
    # the straight line to open_goal is free: it is taken directly
    assert res.path.shape[0] == 2 and np.array_equal(res.path[-1], open_goal)
    # with only goals behind the wall, the path goes around it and ends at one of them
    far = np.array([0.8, 0.2])
    res = rrt_connect(space, start, np.stack([walled, far]), RRTConnectOptions(seed=1))
    assert res.success and _exactly_free(res.path)
    assert any(np.array_equal(res.path[-1], g) for g in (walled, far))
    assert res.path[:, 1].max() > 0.8  # over the wall
    # the nearest goal is enclosed (valid but unreachable): the path ends at the other
    enclosed = np.array([0.15, 0.15])
    opts = RRTConnectOptions(seed=2, time_limit_s=5.0)
    res = rrt_connect(space, start, np.stack([enclosed, far]), opts)
    assert res.success and np.array_equal(res.path[-1], far) and _exactly_free(res.path)


class _Disc:
    """The goal region ``|q - c| <= r`` (membership computed independently of the planner)."""

    def __init__(self, centre: list[float], radius: float) -> None:
        self.c, self.r = np.array(centre), radius
        self.sampled = 0

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(q - self.c) <= self.r)

    def sample(self, rng: np.random.Generator) -> np.ndarray | None:
        self.sampled += 1
        angle, rad = rng.uniform(0, 2 * math.pi), self.r * math.sqrt(rng.random())
        return self.c + rad * np.array([math.cos(angle), math.sin(angle)])


def test_goal_region_is_reached_within_it() -> None:
    space = _space()
    region = _Disc([0.8, 0.5], 0.08)  # inside the cup, beyond the wall
    res = rrt_connect(space, [0.1, 0.5], region, RRTConnectOptions(seed=3))
    assert res.success and region.contains(res.path[-1])
    assert np.linalg.norm(res.path[-1] - region.c) <= region.r
    assert _exactly_free(res.path) and res.log["goal_states"] >= 1
    assert region.sampled >= 1
    # a start inside the region is a one-point path
    inside = rrt_connect(space, [0.8, 0.5], region)
    assert inside.success and inside.path.shape == (1, 2)
    # a region whose samples all collide: the budget is spent, no goal state said so
    walled = _Disc([0.5, 0.4], 0.01)
    none = rrt_connect(space, [0.1, 0.5], walled, RRTConnectOptions(time_limit_s=1.0))
    assert not none.success
    assert none.status in (PlannerStatus.ITERATION_LIMIT, PlannerStatus.TIME_LIMIT)
    assert none.log["goal_states"] == 0.0


def test_panda_rrt_connect_to_a_pose_region() -> None:
    robot = Robot.load("panda", convex_collision=True)
    start = robot.q_default
    tcp = robot.frame_id("panda_hand_tcp")
    here = robot.state(start).frame_placement(tcp)
    robot.add_obstacle(
        Obstacle.box("block", [0.08, 0.04, 0.08], here.translation + np.array([0.0, 0.15, 0.0]))
    )
    space = ConfigurationSpace.from_robot(robot)
    goal_pose = pin.SE3(here.rotation, here.translation + np.array([0.0, 0.3, 0.0]))
    region = PoseGoalRegion(
        robot, "panda_hand_tcp", goal_pose, position_tolerance=0.02, rotation_tolerance=0.1
    )
    res = rrt_connect(space, start, region, RRTConnectOptions(seed=0, time_limit_s=10.0))
    assert res.success
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, res.path[-1])
    assert np.linalg.norm(data.oMf[tcp].translation - goal_pose.translation) <= 0.02 + 1e-9
    gdata = robot.collision_model.createData()
    for a, b in itertools.pairwise(res.path):
        n = max(1, math.ceil(np.linalg.norm(b - a) / 0.01))
        for t in np.arange(n + 1) / n:
            q = a + t * (b - a)
            assert not pin.computeCollisions(
                robot.model, data, robot.collision_model, gdata, q, True
            )
