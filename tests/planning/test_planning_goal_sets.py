"""Several goals and goal regions for RRT, PRM and Lazy PRM (as RRT-Connect, RRT*, PRM*, BIT*).

References independent of the planners: every returned edge is tested against the boxes by an
exact segment-versus-box test (Liang-Barsky), the region's membership is computed here, and
on the Panda the last configuration's pose comes from Pinocchio's forward kinematics and the
path is checked by Pinocchio's ``computeCollisions``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import PlanningError
from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.planner_result import PlannerResult, PlannerStatus
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.rrt import RRTOptions, rrt
from tests.planning.test_planning_rrt_connect_goals import _Disc, _exactly_free, _space

PLANNERS: dict[str, Callable[[ConfigurationSpace, Any, Any, int], PlannerResult]] = {
    "rrt": lambda space, start, goal, seed: rrt(
        space,
        start,
        goal,
        RRTOptions(
            seed=seed, step_size=0.05, goal_bias=0.1, max_iterations=20_000, time_limit_s=20.0
        ),
    ),
    "prm": lambda space, start, goal, seed: prm(
        space, start, goal, PRMOptions(seed=seed, max_iterations=400, k_neighbors=10)
    )[0],
    "lazy_prm": lambda space, start, goal, seed: lazy_prm(
        space,
        start,
        goal,
        PRMOptions(seed=seed, batch_size=200, max_iterations=4000),
        time_limit_s=20.0,
    )[0],
}

START = np.array([0.1, 0.5])
WALLED = np.array([0.8, 0.5])  # inside the cup (open to the left), beyond the wall
FAR = np.array([0.8, 0.2])  # beyond the wall
ENCLOSED = np.array([0.15, 0.15])  # free but inside a closed ring: unreachable


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_several_goals_end_at_a_reachable_one(name: str) -> None:
    plan = PLANNERS[name]
    space = _space()
    with pytest.raises(PlanningError, match=r"goal\[1\] is in collision"):
        plan(space, START, np.stack([WALLED, [0.5, 0.5]]), 0)
    for seed in range(2):
        res = plan(space, START, np.stack([ENCLOSED, WALLED, FAR]), seed)
        assert res.success and res.log["goal_states"] == 3.0
        np.testing.assert_array_equal(res.path[0], START)
        # ends exactly at one of the reachable goals, never at the enclosed one
        assert any(np.array_equal(res.path[-1], g) for g in (WALLED, FAR))
        assert _exactly_free(res.path)
        assert res.log["stopped_by"] == "first solution"
        assert res.log["costs"] == [pytest.approx(res.path_length)]


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_goal_region_is_reached_within_it(name: str) -> None:
    plan = PLANNERS[name]
    space = _space()
    region = _Disc([0.8, 0.5], 0.08)
    res = plan(space, START, region, 3)
    assert res.success and region.contains(res.path[-1]) and _exactly_free(res.path)
    assert res.log["goal_states"] >= 1 and region.sampled >= 1
    inside = plan(space, [0.8, 0.5], region, 0)  # a start inside: a one-point path
    assert inside.success and inside.path.shape == (1, 2)


def test_roadmap_queries_take_goal_sets_and_regions() -> None:
    space = _space()
    goals = np.stack([ENCLOSED, FAR, WALLED])
    roadmap = build_prm(space, PRMOptions(max_iterations=400, seed=1))
    lazy = build_lazy_prm(space, PRMOptions(max_iterations=400, seed=1))
    for res in (prm_query(space, roadmap, START, goals), lazy_prm_query(space, lazy, START, goals)):
        assert res.success and _exactly_free(res.path)
        assert any(np.array_equal(res.path[-1], g) for g in (WALLED, FAR))
    # the shortest of the single-goal answers: the multi-goal query picks the cheapest goal
    singles = [prm_query(space, roadmap, START, g) for g in (FAR, WALLED)]
    best = min(r.log["graph_cost"] for r in singles if r.success)
    assert prm_query(space, roadmap, START, goals).log["graph_cost"] == pytest.approx(best)
    astar = prm_query(space, roadmap, START, goals, PRMOptions(search="astar"))
    assert astar.log["graph_cost"] == pytest.approx(best)
    region = _Disc([0.8, 0.5], 0.08)
    for res in (
        prm_query(space, roadmap, START, region),
        lazy_prm_query(space, lazy, START, region),
    ):
        assert res.success and region.contains(res.path[-1]) and _exactly_free(res.path)
    # a region whose samples all collide: the roadmap reaches none of them; a planner spends
    # its budget (test_planning_left_goal_status.py), no goal state said so
    walled = _Disc([0.5, 0.4], 0.01)
    none = prm_query(space, roadmap, START, walled)
    assert none.status is PlannerStatus.NO_PATH and none.log["goal_states"] == 0.0
    none = rrt(space, START, walled, RRTOptions(max_iterations=300))
    assert none.status is PlannerStatus.ITERATION_LIMIT and none.log["goal_states"] == 0.0


@pytest.mark.parametrize("name", ["rrt", "lazy_prm"])
def test_panda_pose_region(name: str) -> None:
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
    if name == "rrt":
        res = rrt(space, start, region, RRTOptions(seed=0, goal_bias=0.2, time_limit_s=20.0))
    else:
        opts = PRMOptions(seed=0, batch_size=100, max_iterations=2000)
        res = lazy_prm(space, start, region, opts, time_limit_s=20.0)[0]
    assert res.success
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, res.path[-1])
    placement = data.oMf[tcp]
    assert np.linalg.norm(placement.translation - goal_pose.translation) <= 0.02 + 1e-9
    angle = np.linalg.norm(pin.log3(goal_pose.rotation.T @ placement.rotation))
    assert angle <= 0.1 + 1e-9
    gdata = robot.collision_model.createData()
    for a, b in itertools.pairwise(res.path):
        n = max(1, math.ceil(np.linalg.norm(b - a) / 0.01))
        for t in np.arange(n + 1) / n:
            assert not pin.computeCollisions(
                robot.model, data, robot.collision_model, gdata, a + t * (b - a), True
            )
