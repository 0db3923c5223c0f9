"""RRT, goal-biased RRT, RRT-Connect and shortcutting on a 2-D point world."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, PlanningError
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


# The straight line from START to GOAL passes through the gap; these two are blocked by the wall.
S2, G2 = np.array([1.0, 8.0]), np.array([9.0, 8.0])


def test_lazy_rrt_connect_never_crosses_a_wall_thinner_than_the_coarse_step() -> None:
    # 0.06-wide wall with a gap; the coarse pass (0.6) steps over it, the resolution (0.02)
    # cannot: a straight segment crossing the wall spends >= 0.06 inside it.
    thin = np.array([[4.97, 0.0, 5.03, 4.0], [4.97, 6.0, 5.03, 10.0]])
    space = wall_space(resolution=0.02, boxes=thin)
    rejected = 0.0
    for seed in range(6):
        opts = RRTConnectOptions(step_size=1.0, coarse_resolution=0.6, seed=seed)
        res = rrt_connect(space, S2, G2, opts)
        assert res.success
        rejected += res.log["lazy_rejections"]
        fine = wall_space(resolution=0.002, boxes=thin)
        assert fine.path_valid(res.path)
        for tree in res.trees:  # removed nodes have no parent; the others form trees
            assert tree.parents[0] == -1 and np.all(tree.parents < np.arange(tree.size))
    assert rejected > 0  # the fine pass did reject coarse-accepted connections


def test_lazy_and_eager_rrt_connect_check_counts() -> None:
    # Eager: every tree edge checked at delta (the classic algorithm); lazy: fine points only
    # on candidate paths. Same guarantee for the returned path, fewer checks.
    space = wall_space(resolution=0.01)
    eager: list[int] = []
    lazy: list[int] = []
    for seed in range(8):
        for coarse, out in ((None, eager), (0.1, lazy)):
            res = rrt_connect(space, S2, G2, RRTConnectOptions(coarse_resolution=coarse, seed=seed))
            assert res.success and wall_space(resolution=0.001).path_valid(res.path)
            out.append(res.collision_checks)
    assert np.mean(lazy) < 0.8 * np.mean(eager)


def test_rrt_connect_option_errors() -> None:
    space = wall_space()
    with pytest.raises(InvalidInputError, match=r"local_sampling must be in \[0, 1\], got 1.5"):
        rrt_connect(space, START, GOAL, RRTConnectOptions(local_sampling=1.5))
    with pytest.raises(InvalidInputError, match=r"trapped_priority must be in \[0, 1\], got -0.1"):
        rrt_connect(space, START, GOAL, RRTConnectOptions(trapped_priority=-0.1))
    with pytest.raises(InvalidInputError, match="coarse_resolution"):
        rrt_connect(space, START, GOAL, RRTConnectOptions(coarse_resolution=-1.0))
    with pytest.raises(InvalidInputError, match="step_size"):
        rrt_connect(space, START, GOAL, RRTConnectOptions(step_size=0.0))
