"""Task functions of the batch suite (a module of their own so worker processes can import them)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np


def spin(item: Any, rng: np.random.Generator, context: Any) -> int:
    """Busy for ``item`` seconds (a CPU-bound task of known length)."""
    end = time.perf_counter() + float(item)
    n = 0
    while time.perf_counter() < end:
        n += 1
    return n


def spin_plain(seconds: float) -> int:
    """The same task for a plain multiprocessing.Pool."""
    return spin(seconds, None, None)  # type: ignore[arg-type]


def noop(item: Any, rng: np.random.Generator, context: Any) -> Any:
    return item


def mbm_context(nonce: Any = None) -> Any:
    """The campaign's robot; ``nonce`` only tells runs apart (a new one: a new context key)."""
    from taskspace.planning.scene_loader import motionbenchmaker_panda

    return motionbenchmaker_panda()


def mbm_plan(item: Any, rng: np.random.Generator, robot: Any) -> dict[str, Any]:
    """One campaign run: a MotionBenchMaker problem, one seed, compiled and Python RRT-Connect."""
    from taskspace.errors import PlanningError
    from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
    from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
    from taskspace.planning.scene_loader import motionbenchmaker_dir, motionbenchmaker_problems

    scenario, index, seed = item
    problem = motionbenchmaker_problems(motionbenchmaker_dir(), scenario, [index])[0]
    request = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    try:
        space.check_endpoint(request.start, "start")
        space.check_endpoint(request.goal, "goal")
    except PlanningError:
        return {"scenario": scenario, "problem": index, "seed": seed, "valid": False}
    row: dict[str, Any] = {"scenario": scenario, "problem": index, "seed": seed, "valid": True}
    for name, native in (("compiled", True), ("python", False)):
        result = rrt_connect(
            space,
            request.start,
            request.goal,
            RRTConnectOptions(time_limit_s=1.0, seed=seed, native=native),
        )
        row[name] = {
            "solved": bool(result.success),
            "time_s": result.time_s,
            "path_length": result.path_length,
        }
    return row
