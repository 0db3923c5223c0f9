"""OMPL's optimal planners on the planner-arena problems (peer of benchmarks/suites/planner_arena).

Runs in .venv-peers/ompl (see install.sh); taskspace and the arena's scenes are imported from
the source tree, and the validity callback is the problem's own taskspace checker
(``ConfigurationSpace.is_valid``, one configuration per call), at the same resolution
(``setStateValidityCheckingResolution`` = ``delta / max extent``). Objective: path length.
Prints one JSON line: {"runs": [{"planner", "scenario", "problem", "seed", "success",
"time_s", "cost"}, ...]}.
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

from benchmarks.suites.planner_arena import Problem, _problems  # noqa: E402

NAMES = ("RRTstar", "InformedRRTstar", "PRMstar", "LazyPRMstar", "BITstar", "RRTConnect")
PLANNERS = {f"ompl {n}": getattr(og, n) for n in NAMES if hasattr(og, n)}  # bindings vary


def solve(p: Problem, planner_cls: Any, limit: float) -> tuple[bool, float, float]:
    """One query: (solved exactly, time [s], path length)."""
    space = p.space
    dim = space.dim
    state_space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for i in range(dim):
        bounds.setLow(i, float(space.lower[i]))
        bounds.setHigh(i, float(space.upper[i]))
    state_space.setBounds(bounds)
    ss = og.SimpleSetup(state_space)
    buf = np.empty(dim)

    def is_valid(state, buf=buf, dim=dim) -> bool:  # type: ignore[no-untyped-def]
        for i in range(dim):
            buf[i] = state[i]
        return space.is_valid(buf)

    ss.setStateValidityChecker(is_valid)
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(space.edge.resolution / state_space.getMaximumExtent())
    ss.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
    ss.setPlanner(planner_cls(si))
    s, g = state_space.allocState(), state_space.allocState()
    for i in range(dim):
        s[i] = float(p.start[i])
        g[i] = float(p.goal[i])
    ss.setStartAndGoalStates(s, g)
    ss.setup()
    t0 = time.perf_counter()
    status = ss.solve(limit)
    dt = time.perf_counter() - t0
    ok = bool(status) and ss.haveExactSolutionPath()
    return ok, dt, float(ss.getSolutionPath().length()) if ok else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--time", type=float, default=1.0)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument(
        "--checkpoint", type=float, default=None,
        help="also run RRTstar and InformedRRTstar with this limit (runs named NAME@LIMITs)",
    )  # fmt: skip
    args = parser.parse_args()
    ou.setLogLevel(ou.LOG_ERROR)
    runs = []
    for p in _problems(args.quick):
        jobs = [(cls, args.time, name) for name, cls in PLANNERS.items()]
        if args.checkpoint is not None:
            jobs += [
                (PLANNERS[name], args.checkpoint, f"{name}@{args.checkpoint:g}s")
                for name in ("ompl RRTstar", "ompl InformedRRTstar")
                if name in PLANNERS
            ]
        for cls, limit, label in jobs:
            for seed in range(args.seeds):
                ok, dt, cost = solve(p, cls, limit)
                runs.append(
                    {"planner": label, "scenario": p.scenario, "problem": p.index, "seed": seed,
                     "success": ok, "time_s": dt, "cost": cost, "time_limit_s": limit}
                )  # fmt: skip
    print(json.dumps({"runs": runs}))


if __name__ == "__main__":
    main()
