"""The compiled RRT-Connect keeps its check orders per thread across plans (#22): a plan gives the
same answers whatever was planned before it in its thread (other strides, other resolutions,
lines longer than the kept orders) and in a new thread (nothing kept)."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import pytest

from taskspace._native import planning_kernel, status
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

pytestmark = [
    pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}"),
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
]


@pytest.fixture(scope="module")
def problem() -> tuple[Any, Any, Any]:
    robot = motionbenchmaker_panda()
    assert ROOT is not None
    req = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0].apply(robot)
    return robot, req.start, req.goal


def _plan(robot: Any, start: Any, goal: Any, resolution: float, coarse: float | None) -> Any:
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=resolution))
    opts = RRTConnectOptions(
        seed=4, coarse_resolution=coarse, checker="spheres_only", validator="spheres"
    )
    res = rrt_connect(space, start, goal, opts)
    assert res.success
    return res


def _key(res: Any) -> tuple[bytes, int, int, int]:
    return (res.path.tobytes(), res.collision_checks, res.iterations, res.edge_checks)


# (resolution, coarse resolution): strides 5, 3, 1 (no lazy pass), 10 and 7 (the kernel keeps
# the orders of 4 strides per thread: the fifth's are the plan's own); the last: a full step of
# 0.5 / 0.0004 = 1250 segments, above the 1024 kept per stride
CASES = ((0.03, 0.15), (0.03, 0.09), (0.03, None), (0.015, 0.15), (0.03, 0.21), (0.0004, 0.004))


def test_plans_do_not_depend_on_earlier_plans_or_the_thread(problem: tuple[Any, Any, Any]) -> None:
    robot, start, goal = problem
    first = {case: _key(_plan(robot, start, goal, *case)) for case in CASES}
    again = {case: _key(_plan(robot, start, goal, *case)) for case in reversed(CASES)}
    assert again == first
    fresh: dict[tuple[float, float | None], tuple[bytes, int, int, int]] = {}

    def worker(case: tuple[float, float | None]) -> None:  # a new thread: nothing kept
        fresh[case] = _key(_plan(robot, start, goal, *case))

    for case in CASES:
        thread = threading.Thread(target=worker, args=(case,))
        thread.start()
        thread.join()
    assert fresh == first


def test_long_steps_are_checked_at_the_resolution(problem: tuple[Any, Any, Any]) -> None:
    """Steps longer than the kept orders (1250 segments): the returned path is free for the
    exact checker at every point of the resolution."""
    robot, start, goal = problem
    resolution = 0.0004
    res = _plan(robot, start, goal, resolution, 0.004)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=resolution))
    longest = max(float(np.linalg.norm(b - a)) for a, b in zip(res.path[:-1], res.path[1:]))
    assert longest / resolution > 1024  # the orders of this plan were not the kept ones
    for a, b in zip(res.path[:-1], res.path[1:]):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / resolution - 1e-12))
        points = a + (np.arange(n + 1) / n)[:, None] * (b - a)
        assert space.checker.are_valid(points).all()
