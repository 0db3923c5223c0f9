"""Gaps found by the issue-22 audit (H7): messages, roadmap export, the arena's cost rows.

References are written here by hand: the expected adjacency lists of a small graph, and the
medians and ratios of a hand-filled arena database.
"""

from __future__ import annotations

import itertools
import math
import sqlite3

import numpy as np
import pinocchio as pin
import pytest

from benchmarks.suites import planner_arena as arena
from taskspace.errors import InvalidInputError, PlanningError
from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.prm_star import (
    PRMStarOptions,
    _Graph,
    _roadmap,
    lazy_prm_star,
    prm_star,
)
from taskspace.planning.shortcut import shortcut_path
from taskspace.planning.smoothing import smooth_bspline
from tests.planning._planning_worlds import wall_space

THROUGH_THE_WALL = [[1.0, 2.0], [9.0, 2.0]]  # free end points, the edge crosses the wall


@pytest.mark.parametrize("fn", [smooth_bspline, shortcut_path])
def test_colliding_input_error_names_the_function_called(fn) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(PlanningError, match=f"{fn.__name__} needs a collision-free path"):
        fn(wall_space(resolution=0.02), THROUGH_THE_WALL)


def _small_graph() -> _Graph:
    g = _Graph(2)
    g.add_nodes(np.arange(10.0).reshape(5, 2))
    # edges (i < j), cost, status: 1 free, 0 unchecked, -1 colliding; in two batches
    g.add_edges(
        np.array([[0, 1], [1, 3], [0, 2]]), np.array([1.0, 2.0, 3.0]), np.array([1, 0, 1], np.int8)
    )
    g.add_edges(
        np.array([[2, 3], [1, 4], [0, 3]]), np.array([4.0, 5.0, 6.0]), np.array([-1, 1, 0], np.int8)
    )
    return g


@pytest.mark.parametrize("lazy", [False, True])
def test_roadmap_adjacency_is_the_edge_list_in_both_directions(lazy: bool) -> None:
    rm = _roadmap(_small_graph(), (7, 3), lazy)
    free = {0: [(1, 1.0), (2, 3.0)], 1: [(0, 1.0), (4, 5.0)], 2: [(0, 3.0)], 3: [], 4: [(1, 5.0)]}
    unchecked = {0: [(3, 6.0)], 1: [(3, 2.0)], 3: [(1, 2.0), (0, 6.0)]}  # kept by lazy roadmaps
    for node in range(5):
        expected = free[node] + (unchecked.get(node, []) if lazy else [])
        assert sorted(rm.adjacency[node]) == sorted(expected)
    assert rm.nodes.shape == (5, 2)
    assert (rm.world_version, rm.model_version) == (7, 3)


def test_roadmap_of_a_graph_without_edges() -> None:
    g = _Graph(2)
    g.add_nodes(np.zeros((3, 2)))
    assert _roadmap(g, (None, None), lazy=True).adjacency == [[], [], []]


def _db(runs: list[tuple[str, str, int, float, bool, float | None]]) -> sqlite3.Connection:
    db = sqlite3.connect(":memory:")
    db.executescript(arena.SCHEMA)
    for planner, scenario, problem, limit, ok, cost in runs:
        db.execute(
            "INSERT INTO runs (planner, scenario, problem, seed, time_limit_s, success, cost) "
            "VALUES (?, ?, ?, 0, ?, ?, ?)",
            (planner, scenario, problem, limit, int(ok), cost),
        )
    return db


def test_cost_rows_put_ours_beside_ompls_after_each_budget() -> None:
    short = arena.checkpoint_name
    runs = [
        # after 1 s: problem 0 ours 2, 4 (median 3) vs OMPL 6; problem 1 ours 5 vs OMPL 5
        ("rrt_star", "s", 0, 1.0, True, 2.0),
        ("rrt_star", "s", 0, 1.0, True, 4.0),
        ("rrt_star", "s", 1, 1.0, True, 5.0),
        ("rrt_star", "s", 1, 1.0, False, None),
        ("ompl RRTstar", "s", 0, 1.0, True, 6.0),
        ("ompl RRTstar", "s", 1, 1.0, True, 5.0),
        # after 0.1 s: ours 8 vs OMPL unsolved on problem 0 (no ratio), 4 vs 2 on problem 1
        (short("rrt_star", 0.1), "s", 0, 0.1, True, 8.0),
        (short("rrt_star", 0.1), "s", 1, 0.1, True, 4.0),
        (short("ompl RRTstar", 0.1), "s", 0, 0.1, False, None),
        (short("ompl RRTstar", 0.1), "s", 1, 0.1, True, 2.0),
        # informed RRT* without OMPL's runs
        ("informed_rrt_star", "s", 0, 1.0, True, 3.0),
    ]
    rows = {r.method: r.extra for r in arena.cost_rows(_db(runs))}
    long = rows["rrt_star cost after 1 s"]
    assert long["success"] == 0.75 and long["median_cost"] == 4.0
    assert long["ompl_success"] == 1.0 and long["ompl_median_cost"] == 5.5
    assert long["cost_ratio"] == pytest.approx(np.median([3.0 / 6.0, 5.0 / 5.0]))
    quick = rows["rrt_star cost after 0.1 s"]
    assert quick["budget_s"] == 0.1 and quick["median_cost"] == 6.0
    assert quick["ompl_success"] == 0.5 and quick["cost_ratio"] == pytest.approx(2.0)
    informed = rows["informed_rrt_star cost after 1 s"]
    assert informed["median_cost"] == 3.0 and "cost_ratio" not in informed
    assert "informed_rrt_star cost after 0.1 s" not in rows  # no runs with that budget
    assert math.isclose(arena.CHECKPOINT_S, 0.1)


def test_base_bounds_on_a_fixed_base_robot_are_refused() -> None:
    """They were silently ignored: a user thought the base was sampled in that box."""
    robot = Robot.load("ur5")
    with pytest.raises(InvalidInputError, match="no JointModelPlanar or JointModelFreeFlyer"):
        ConfigurationSpace.from_robot(robot, base_lower=[-3, -3], base_upper=[3, 3])
    with pytest.raises(InvalidInputError, match="base_lower/base_upper"):
        JointManifold(robot.model, base_upper=[1, 1])
    assert ConfigurationSpace.from_robot(robot).dim == robot.model.nq  # without them: fine


@pytest.fixture(scope="module")
def panda_block():  # type: ignore[no-untyped-def]
    """Panda turning its base joint from -1.2 to 1.2 rad through a block at its hand."""
    robot = Robot.load("panda", convex_collision=True)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_default)
    hand = data.oMf[robot.model.getFrameId("panda_hand_tcp")].translation
    robot.add_obstacle(Obstacle.box("block", [0.12, 0.12, 0.12], hand.copy()))
    space = ConfigurationSpace.from_robot(robot)
    start, goal = robot.q_default.copy(), robot.q_default.copy()
    start[0], goal[0] = -1.2, 1.2
    assert not space.motion_valid(start, goal)  # the straight path goes through the block
    return robot, space, start, goal


def _free_under_pinocchio(robot: Robot, path: np.ndarray, step: float = 0.004) -> bool:
    """Pinocchio's computeCollisions every ``step`` rad along the path (independent check)."""
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(np.linalg.norm(b - a) / step))
        for t in np.arange(n + 1) / n:
            q = a + t * (b - a)
            if pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True):
                return False
    return True


@pytest.mark.parametrize("planner", ["bit_star", "prm_star", "lazy_prm_star"])
def test_optimal_planners_certify_their_paths(panda_block, planner: str) -> None:  # type: ignore[no-untyped-def]
    """Only RRT-Connect and RRT* had ``certify``; BIT*, PRM* and Lazy PRM* now too."""
    robot, space, start, goal = panda_block
    if planner == "bit_star":
        opts = BITStarOptions(certify=True, max_iterations=300, time_limit_s=None, seed=1)
        result = bit_star(space, start, goal, opts)
    else:
        fn = prm_star if planner == "prm_star" else lazy_prm_star
        star = PRMStarOptions(certify=True, max_iterations=300, time_limit_s=None, seed=1)
        result, roadmap = fn(space, start, goal, star)
        assert roadmap.size > 0 if planner == "prm_star" else roadmap.roadmap.size > 0
    assert result.success and result.log["certified"] == 1.0
    assert result.log["min_distance"] >= 1e-4
    assert _free_under_pinocchio(robot, result.path)


@pytest.mark.parametrize("planner", ["bit_star", "prm_star"])
def test_uncertifiable_optimal_paths_are_reported(panda_block, planner: str) -> None:  # type: ignore[no-untyped-def]
    _, space, start, goal = panda_block
    if planner == "bit_star":
        opts = BITStarOptions(
            certify=True, certify_retries=1, certify_tolerance=5.0, max_iterations=200,
            time_limit_s=None, seed=1,
        )  # fmt: skip
        result = bit_star(space, start, goal, opts)
    else:
        star = PRMStarOptions(
            certify=True, certify_retries=1, certify_tolerance=5.0, max_iterations=200,
            time_limit_s=None, seed=1,
        )  # fmt: skip
        result = prm_star(space, start, goal, star)[0]
    assert not result.success and result.status is PlannerStatus.UNCERTIFIED
    assert result.log["certify_attempts"] == 2.0 and result.log["certified"] == 0.0
    with pytest.raises(InvalidInputError, match="certify=True needs a space built on a robot"):
        bit_star(wall_space(), [1, 5], [9, 5], BITStarOptions(certify=True))
    with pytest.raises(InvalidInputError, match="certify=True needs a space built on a robot"):
        prm_star(wall_space(), [1, 5], [9, 5], PRMStarOptions(certify=True))


def _walled_in_goal():  # type: ignore[no-untyped-def]
    """A 2-D space whose goal is enclosed by a ring: no path, so Lazy PRM grows until a limit."""
    from taskspace.planning.collision_checker import FunctionChecker
    from taskspace.planning.configuration_space import EdgeCheckOptions

    def free(q: np.ndarray) -> np.ndarray:
        r = np.linalg.norm(np.atleast_2d(q) - 0.8, axis=1)
        return ~((r > 0.1) & (r < 0.12))

    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.005)
    )
    return space, [0.1, 0.1], [0.8, 0.8]


def test_lazy_prm_follows_the_options_time_limit() -> None:
    """PRMOptions.time_limit_s was silently ignored: the keyword's default 1 s ran instead."""
    from taskspace.planning.lazy_prm import lazy_prm
    from taskspace.planning.prm import PRMOptions

    space, start, goal = _walled_in_goal()
    result, _ = lazy_prm(space, start, goal, PRMOptions(batch_size=50, time_limit_s=0.0))
    # stopped by the options before any round (limits.py's edge cases: time_limit_s=0 stops
    # before any check; the first round always ran before stop 23)
    assert not result.success and result.log["growth_rounds"] == 0.0
    result, _ = lazy_prm(space, start, goal, PRMOptions(batch_size=50), time_limit_s=0.0)
    assert result.log["growth_rounds"] == 0.0  # the keyword alone
    with pytest.raises(InvalidInputError, match="disagree"):
        lazy_prm(space, start, goal, PRMOptions(time_limit_s=2.0), time_limit_s=0.5)
    result, _ = lazy_prm(  # both, agreeing: fine
        space, start, goal, PRMOptions(batch_size=50, time_limit_s=0.0), time_limit_s=0.0
    )
    assert result.log["growth_rounds"] == 0.0
