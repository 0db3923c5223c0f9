"""OMPL RRTConnect on the MotionBenchMaker Panda problems, with taskspace's collision checker.

Runs in .venv-peers/ompl (pip install ompl numpy scipy pin coal example-robot-data
example-robot-data-loaders pyyaml); taskspace is imported from the source tree. The validity
callback is taskspace's :class:`CollisionChecker` (``is_valid``, one configuration per call).
The resolution is the same as taskspace's (``setStateValidityCheckingResolution`` =
``delta / max extent``). Two settings of the range (OMPL's ``maxDistance``) are measured:
``same`` (taskspace's step size) and ``default`` (OMPL's own choice, 0.2 x max extent).
Prints one JSON line: {"variants": {variant: {scenario: {"valid", "solved", "times",
"checks", "lengths"}}}, "range_default": ...}.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

from _checkout import use_checkout

ROOT = use_checkout()  # src/ and the built kernels (a fair checker for the peer)

import numpy as np  # noqa: E402
from ompl import base as ob  # noqa: E402
from ompl import geometric as og  # noqa: E402
from ompl import util as ou  # noqa: E402

from taskspace.errors import PlanningError  # noqa: E402
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions  # noqa: E402
from taskspace.planning.scene_loader import (  # noqa: E402
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)

DATA = motionbenchmaker_dir()


def solve_one(
    space: ConfigurationSpace,
    start: np.ndarray,
    goal: np.ndarray,
    rng: float | None,
    time_limit: float,
    resolution: float,
) -> tuple[float, bool, int, float, float]:
    """One OMPL RRTConnect query: (time [s], solved, checks, path length [rad], range used)."""
    checker = space.checker
    dim = space.dim
    state_space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for i in range(dim):
        bounds.setLow(i, float(space.lower[i]))
        bounds.setHigh(i, float(space.upper[i]))
    state_space.setBounds(bounds)
    ss = og.SimpleSetup(state_space)
    buf = np.empty(dim)

    def is_valid(state, buf=buf, checker=checker, dim=dim) -> bool:  # type: ignore[no-untyped-def]
        for i in range(dim):
            buf[i] = state[i]
        return checker.is_valid(buf)

    ss.setStateValidityChecker(is_valid)
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(resolution / state_space.getMaximumExtent())
    planner = og.RRTConnect(si)
    if rng is not None:
        planner.setRange(rng)
    ss.setPlanner(planner)
    s, g = state_space.allocState(), state_space.allocState()
    for i in range(dim):
        s[i] = float(start[i])
        g[i] = float(goal[i])
    ss.setStartAndGoalStates(s, g)
    ss.setup()
    used = planner.getRange()
    c0 = checker.checks
    t0 = time.perf_counter()
    status = ss.solve(time_limit)
    dt = time.perf_counter() - t0
    ok = bool(status) and ss.haveExactSolutionPath() and dt <= time_limit
    length = float(ss.getSolutionPath().length()) if ok else float("nan")
    return dt, ok, checker.checks - c0, length, used


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--problems", type=int, default=None, help="first N problems")
    parser.add_argument("--resolution", type=float, default=0.03)
    parser.add_argument("--range", type=float, default=0.5)
    parser.add_argument("--time", type=float, default=1.0)
    parser.add_argument("--variants", default="same,default")
    parser.add_argument("--scenarios", default=",".join(MOTIONBENCHMAKER_SCENARIOS))
    args = parser.parse_args()
    ou.setLogLevel(ou.LOG_WARN)
    count = args.problems or (5 if args.quick else 50)
    indices = list(range(1, count + 1))
    robot = motionbenchmaker_panda()
    variants = args.variants.split(",")
    out: dict[str, dict[str, dict[str, Any]]] = {v: {} for v in variants}
    range_default = None
    for scenario in args.scenarios.split(","):
        rows: dict[str, dict[str, Any]] = {
            v: {"valid": 0, "solved": 0, "times": [], "checks": [], "lengths": []} for v in variants
        }
        for problem in motionbenchmaker_problems(DATA, scenario, indices):
            req = problem.apply(robot)
            space = ConfigurationSpace.from_robot(
                robot, edge=EdgeCheckOptions(resolution=args.resolution)
            )
            try:
                space.check_endpoint(req.start, "start")
                space.check_endpoint(req.goal, "goal")
            except PlanningError:
                continue
            for v in variants:
                rng = args.range if v == "same" else None
                dt, ok, checks, length, used = solve_one(
                    space, req.start, req.goal, rng, args.time, args.resolution
                )
                if v == "default":
                    range_default = used
                row = rows[v]
                row["valid"] += 1
                row["solved"] += int(ok)
                row["times"].append(dt)
                row["checks"].append(checks)
                row["lengths"].append(length)
        for v in variants:
            out[v][scenario] = rows[v]
    print(
        json.dumps(
            {
                "variants": out,
                "range_default": range_default,
                "note": "OMPL RRTConnect, taskspace checker as Python callback",
            }
        )
    )


if __name__ == "__main__":
    main()
