"""RRT, goal-biased RRT, RRT-Connect and shortcutting on a 2-D point world."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import PlanningError
from taskspace.planning.configuration_space import path_length
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.shortcut import shortcut_path
from tests.planning._planning_worlds import wall_space

START, GOAL = np.array([1.0, 1.0]), np.array([9.0, 9.0])


def _assert_path_ok(path: np.ndarray, resolution: float) -> None:
    np.testing.assert_allclose(path[0], START)
    np.testing.assert_allclose(path[-1], GOAL)
    fine = wall_space(resolution=resolution / 10)
    assert fine.path_valid(path)


@pytest.mark.parametrize("seed", range(5))
def test_rrt_connect_path_is_free_at_finer_resolution(seed: int) -> None:
    space = wall_space(resolution=0.05)
    res = rrt_connect(space, START, GOAL, RRTConnectOptions(step_size=1.0, seed=seed))
    assert res.success and res.status is PlannerStatus.SOLVED
    _assert_path_ok(res.path, 0.05)
    # Through the gap: some waypoint segment crosses x = 5 with 4 <= y <= 6.
    assert res.path_length >= np.linalg.norm(GOAL - START) - 1e-9
    assert res.collision_checks > 0 and len(res.trees) == 2
    short = shortcut_path(space, res.path)
    assert short.length_after <= short.length_before + 1e-12
    _assert_path_ok(short.path, 0.05)
    assert short.length_after == pytest.approx(path_length(short.path))


@pytest.mark.parametrize("beta", [0.0, 0.2])
def test_rrt_and_goal_bias(beta: float) -> None:
    space = wall_space(resolution=0.05)
    res = rrt(space, START, GOAL, RRTOptions(step_size=0.5, goal_bias=beta, seed=2))
    assert res.success
    _assert_path_ok(res.path, 0.05)
    tree = res.trees[0]
    # Every tree edge is at most alpha long and lies in Q_free.
    seg = np.linalg.norm(tree.nodes[1:] - tree.nodes[tree.parents[1:]], axis=1)
    assert np.all(seg <= 0.5 + 1e-9)


def test_goal_bias_reaches_goal_with_fewer_nodes() -> None:
    from taskspace.planning.collision_checker import FunctionChecker
    from taskspace.planning.configuration_space import ConfigurationSpace
    from tests.planning._planning_worlds import box_free

    empty = ConfigurationSpace([0, 0], [10, 10], FunctionChecker(box_free(np.zeros((0, 4)))))
    sizes = {}
    for beta in (0.0, 0.5):
        n = [
            rrt(empty, START, GOAL, RRTOptions(step_size=0.3, goal_bias=beta, seed=s)).iterations
            for s in range(5)
        ]
        sizes[beta] = np.mean(n)
    assert sizes[0.5] < sizes[0.0]


def test_rrt_growth_without_goal_counts_iterations() -> None:
    space = wall_space()
    res = rrt(space, START, None, RRTOptions(max_iterations=300, step_size=0.5, seed=0))
    assert not res.success and res.status is PlannerStatus.ITERATION_LIMIT
    assert res.iterations == 300 and 1 < res.trees[0].size <= 301


def test_limits_and_seeding() -> None:
    space = wall_space()
    a = rrt_connect(space, START, GOAL, RRTConnectOptions(seed=7))
    b = rrt_connect(space, START, GOAL, RRTConnectOptions(seed=7))
    np.testing.assert_array_equal(a.path, b.path)
    walled = wall_space(boxes=np.array([[4.5, 0.0, 5.5, 10.0]]))  # no gap: unsolvable
    res = rrt_connect(walled, START, GOAL, RRTConnectOptions(max_iterations=200, time_limit_s=None))
    assert not res.success and res.status is PlannerStatus.ITERATION_LIMIT
    assert res.path.shape == (0, 2) and res.path_length == np.inf
    res = rrt_connect(walled, START, GOAL, RRTConnectOptions(time_limit_s=0.05))
    assert res.status is PlannerStatus.TIME_LIMIT and 0.05 <= res.time_s < 0.5


def test_start_goal_errors() -> None:
    space = wall_space()
    with pytest.raises(
        PlanningError, match=r"start is in collision: point \[5. 2.\] is inside a box"
    ):
        rrt_connect(space, [5.0, 2.0], GOAL)
    with pytest.raises(PlanningError, match=r"goal is outside the joint limits: q\[0\]=11"):
        rrt(space, START, [11.0, 5.0])
    with pytest.raises(PlanningError, match="must have shape"):
        rrt_connect(space, [1.0, 1.0, 1.0], GOAL)
