"""pyroboplan's RRT-Connect on the MotionBenchMaker Panda problems.

Runs in .venv-peers/pyroboplan (pip install pyroboplan numpy pyyaml example-robot-data==5.0.0
example-robot-data-loaders==5.0.0); taskspace is imported from the source tree only to load
the same robot model (Panda, fingers locked at 0.04 m, convex-hull collision geometry) and the
same scenes. pyroboplan plans with its OWN collision checking (Pinocchio ``computeCollisions``
over every pair of the geometry model, one configuration per call, no broad phase), which is
how a pyroboplan user runs it: ``RRTPlannerOptions(rrt_connect=True, bidirectional_rrt=True,
max_step_size=resolution, max_planning_time=time)`` with pyroboplan's default
``max_connection_dist = inf``. pyroboplan's connect differs from Kuffner-LaValle's: the
extended tree connects greedily towards the sample, then ONE straight segment to the other
tree's nearest node is tried, only if it is shorter than ``max_connection_dist``; so that
distance is both the step and the connection radius, and with taskspace's step (0.5 rad) the
trees almost never connect (0 of 10 easy problems in 1 s), hence pyroboplan's default.
Prints one JSON line: {"scenarios": {name: {"valid", "solved", "times", "lengths"}}}.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "src"))

import numpy as np  # noqa: E402
from pyroboplan.planning.rrt import RRTPlanner, RRTPlannerOptions  # noqa: E402

from taskspace.errors import PlanningError  # noqa: E402
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions  # noqa: E402
from taskspace.planning.scene_loader import (  # noqa: E402
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)

DATA = motionbenchmaker_dir()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--problems", type=int, default=None, help="first N problems")
    parser.add_argument("--resolution", type=float, default=0.03)
    parser.add_argument("--range", type=float, default=float("inf"))
    parser.add_argument("--time", type=float, default=1.0)
    parser.add_argument("--scenarios", default=",".join(MOTIONBENCHMAKER_SCENARIOS))
    args = parser.parse_args()
    count = args.problems or (5 if args.quick else 50)
    indices = list(range(1, count + 1))
    robot = motionbenchmaker_panda()
    out: dict[str, dict[str, object]] = {}
    for scenario in args.scenarios.split(","):
        times: list[float] = []
        lengths: list[float] = []
        valid = solved = 0
        for k, problem in enumerate(motionbenchmaker_problems(DATA, scenario, indices)):
            req = problem.apply(robot)
            space = ConfigurationSpace.from_robot(
                robot, edge=EdgeCheckOptions(resolution=args.resolution)
            )
            try:
                space.check_endpoint(req.start, "start")
                space.check_endpoint(req.goal, "goal")
            except PlanningError:
                continue
            valid += 1
            options = RRTPlannerOptions(
                max_step_size=args.resolution,
                max_connection_dist=args.range,
                rrt_connect=True,
                bidirectional_rrt=True,
                max_planning_time=args.time,
                rng_seed=k,
                fast_return=True,
            )
            planner = RRTPlanner(robot.model, robot.collision_model, options=options)
            with contextlib.redirect_stdout(io.StringIO()):  # pyroboplan prints progress
                t0 = time.perf_counter()
                path = planner.plan(req.start.copy(), req.goal.copy())
                dt = time.perf_counter() - t0
            ok = bool(path) and dt <= args.time
            times.append(dt)
            solved += int(ok)
            if ok:
                arr = np.asarray(path)
                lengths.append(float(np.linalg.norm(np.diff(arr, axis=0), axis=1).sum()))
            else:
                lengths.append(float("nan"))
        out[scenario] = {"valid": valid, "solved": solved, "times": times, "lengths": lengths}
    print(
        json.dumps({"scenarios": out, "note": "pyroboplan RRTPlanner (rrt_connect), own checker"})
    )


if __name__ == "__main__":
    main()
