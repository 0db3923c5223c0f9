"""RRT-Connect on MotionBenchMaker Panda problems; paths re-checked at a finer resolution."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from taskspace.errors import PlanningError
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from taskspace.planning.shortcut import shortcut_path

ROOT = Path("/work/shared/benchmarks/motionbenchmaker_panda")
pytestmark = pytest.mark.skipif(not ROOT.is_dir(), reason="MotionBenchMaker files not present")


@pytest.mark.parametrize(
    ("scenario", "index"), [("table_pick", 1), ("box", 2), ("table_under_pick", 2)]
)
def test_rrt_connect_solves_within_one_second(scenario: str, index: int) -> None:
    robot = motionbenchmaker_panda()
    problem = motionbenchmaker_problems(ROOT, scenario, [index])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    res = rrt_connect(space, req.start, req.goal, RRTConnectOptions(time_limit_s=1.0, seed=0))
    assert res.success, res.status
    assert res.time_s < 1.0
    np.testing.assert_allclose(res.path[0], req.start)
    np.testing.assert_allclose(res.path[-1], req.goal)
    short = shortcut_path(space, res.path)
    for path in (res.path, short.path):
        assert space.path_valid(path, resolution=0.0075)
    assert short.length_after <= res.path_length + 1e-9


def test_goal_in_collision_names_pairs() -> None:
    robot = motionbenchmaker_panda(finger_opening=0.001)  # closed fingers hit the can
    problem = motionbenchmaker_problems(ROOT, "bookshelf_small", [1])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot)
    with pytest.raises(
        PlanningError, match=r"goal is in collision: colliding pairs: panda_.*finger.* <-> Can3"
    ):
        rrt_connect(space, req.start, req.goal)
