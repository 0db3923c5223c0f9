"""RRT-Connect on MotionBenchMaker Panda problems; paths re-checked at a finer resolution."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import PlanningError
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.shortcut import shortcut_path
from tests.planning._mbm import ROOT, SKIP_REASON, reference_free

pytestmark = pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)


@pytest.mark.parametrize(
    ("scenario", "index"), [("table_pick", 1), ("box", 2), ("bookshelf_small", 3)]
)
def test_rrt_connect_solves_within_one_second(scenario: str, index: int) -> None:
    robot = motionbenchmaker_panda()
    problem = motionbenchmaker_problems(ROOT, scenario, [index])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    rejections = 0.0
    for seed in range(3):
        res = rrt_connect(
            space, req.start, req.goal, RRTConnectOptions(time_limit_s=1.0, seed=seed)
        )
        assert res.success, res.status
        assert res.time_s < 1.0
        rejections += res.log["lazy_rejections"]
        np.testing.assert_allclose(res.path[0], req.start)
        np.testing.assert_allclose(res.path[-1], req.goal)
        short = shortcut_path(space, res.path)
        assert short.length_after <= res.path_length + 1e-9
        for path in (res.path, short.path):
            # The promise: every edge is free at the resolution delta = 0.03 rad (slide 3:32),
            # checked by Pinocchio without our broad phase, batching or lazy passes.
            assert reference_free(robot, path, 0.03).all()
            # Four times finer, a path may graze an obstacle between two checked points, but
            # only there: a planner that skipped the fine pass would cross obstacles.
            assert reference_free(robot, path, 0.0075).mean() > 0.98


def test_lazy_fine_pass_rejects_paths_that_the_coarse_pass_accepts() -> None:
    robot = motionbenchmaker_panda()
    problem = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    total = 0.0
    for seed in range(4):
        opts = RRTConnectOptions(coarse_resolution=0.3, time_limit_s=2.0, seed=seed)
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success
        total += res.log["lazy_rejections"]
        assert reference_free(robot, res.path, 0.03).all()
    assert total > 0  # the coarse pass alone would have returned colliding paths


def test_goal_in_collision_names_pairs() -> None:
    robot = motionbenchmaker_panda(finger_opening=0.001)  # closed fingers hit the can
    problem = motionbenchmaker_problems(ROOT, "bookshelf_small", [1])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot)
    with pytest.raises(
        PlanningError, match=r"goal is in collision: colliding pairs: panda_.*finger.* <-> Can3"
    ):
        rrt_connect(space, req.start, req.goal)


def test_local_sampling_frees_a_trapped_goal_tree() -> None:
    # table_under_pick 13: the goal (gripper around an object under a table) admits almost no
    # 0.5 rad step towards uniform samples; the goal tree stays at a few nodes.
    robot = motionbenchmaker_panda()
    req = motionbenchmaker_problems(ROOT, "table_under_pick", [13])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    iterations: dict[float, list[int]] = {0.0: [], 0.5: []}
    for local in iterations:
        for seed in range(3):
            opts = RRTConnectOptions(local_sampling=local, time_limit_s=None, seed=seed)
            res = rrt_connect(space, req.start, req.goal, opts)
            assert res.success
            iterations[local].append(res.iterations)
    assert np.median(iterations[0.5]) < np.median(iterations[0.0]) / 3


@pytest.mark.parametrize("native", [True, False])
def test_trapped_tree_takes_the_other_trees_turns(native: bool) -> None:
    # cage 3: the goal (inside the cage) is trapped; the start tree grows in free space. With
    # trapped_priority the goal tree takes some of the start tree's turns and keeps about a
    # quarter of its nodes; with 0 the trees alternate (no turn taken) and it falls behind.
    robot = motionbenchmaker_panda()
    req = motionbenchmaker_problems(ROOT, "cage", [3])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    share: dict[float, list[float]] = {0.0: [], 0.75: []}
    turns: dict[float, float] = {0.0: 0.0, 0.75: 0.0}
    for priority in share:
        for seed in range(4):
            opts = RRTConnectOptions(
                trapped_priority=priority, native=native, time_limit_s=None, seed=seed
            )
            res = rrt_connect(space, req.start, req.goal, opts)
            assert res.success
            assert reference_free(robot, res.path, 0.03).mean() > 0.98
            goal, start = res.log["goal_tree_nodes"], res.log["start_tree_nodes"]
            share[priority].append(goal / (goal + start))
            turns[priority] += res.log["trapped_turns"]
    assert turns[0.0] == 0 and turns[0.75] > 0
    assert np.median(share[0.75]) > np.median(share[0.0]) + 0.02
