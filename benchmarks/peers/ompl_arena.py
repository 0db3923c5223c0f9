"""OMPL's optimal planners on the planner-arena problems (peer of benchmarks/suites/planner_arena).

Runs in .venv-peers/ompl (see install.sh); taskspace and the arena's scenes are imported from
the source tree, and the validity callback is the problem's own taskspace checker
(``ConfigurationSpace.is_valid``, one configuration per call), at the same resolution
(``setStateValidityCheckingResolution`` = ``delta / max extent``). Objective: path length.

Output: JSON lines on stdout. First a header, ``{"ompl_version": "2.0.1", "planners": [...],
"missing": ["LazyPRMstar"]}``: the planners of :data:`NAMES` this OMPL's bindings lack are
listed, never dropped silently. Then, per problem (``k``, a position in the arena's problem
list ``planner_arena.problem_specs``), one line ``{"run": {"planner", "scenario", "problem",
"seed", "success", "time_s", "cost", "time_limit_s"}}`` per run and ``{"done": k}``.
``--serve``: the problems to run are read from stdin, one JSON ``{"k": k}`` a line (the arena
interleaves them with its own runs, so an interrupted arena has both sides of every problem
it finished); otherwise every problem is run in order. ``--header``: the header only.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import sys
import time
from typing import Any

from _checkout import use_checkout

ROOT = use_checkout()  # src/ and the built kernels (a fair checker for the peer)

import numpy as np  # noqa: E402
from ompl import base as ob  # noqa: E402
from ompl import geometric as og  # noqa: E402
from ompl import util as ou  # noqa: E402

from benchmarks.suites.planner_arena import Problem, problem_specs  # noqa: E402

NAMES = ("RRTstar", "InformedRRTstar", "PRMstar", "LazyPRMstar", "BITstar", "RRTConnect")
PLANNERS = {f"ompl {n}": getattr(og, n) for n in NAMES if hasattr(og, n)}  # bindings vary
MISSING = [n for n in NAMES if not hasattr(og, n)]


def ompl_version() -> str:
    """The OMPL bindings' version (the package's, else the module's, else "unknown")."""
    try:
        return importlib.metadata.version("ompl")
    except importlib.metadata.PackageNotFoundError:
        import ompl

        return str(getattr(ompl, "__version__", "unknown"))


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


def emit(obj: dict[str, Any]) -> None:
    """One JSON line on stdout, flushed (the arena reads them as they come)."""
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


def run_problem(p: Problem, args: argparse.Namespace) -> None:
    """Every planner (and the checkpoint runs) on one problem, a line per run.

    ``seed`` labels the repetition (OMPL's generator is seeded once per process by OMPL).
    """
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
            emit(
                {"run": {"planner": label, "scenario": p.scenario, "problem": p.index,
                         "seed": seed, "success": ok, "time_s": dt,
                         "cost": cost if ok else None, "time_limit_s": limit}}
            )  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--time", type=float, default=1.0)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument(
        "--checkpoint", type=float, default=None,
        help="also run RRTstar and InformedRRTstar with this limit (runs named NAME@LIMITs)",
    )  # fmt: skip
    parser.add_argument("--serve", action="store_true", help="problems from stdin")
    parser.add_argument("--header", action="store_true", help="print the header and exit")
    args = parser.parse_args()
    ou.setLogLevel(ou.LOG_ERROR)
    emit({"ompl_version": ompl_version(), "planners": list(PLANNERS), "missing": MISSING})
    if args.header:
        return
    specs = problem_specs(args.quick)
    if args.serve:
        for line in sys.stdin:
            if not line.strip():
                continue
            k = int(json.loads(line)["k"])
            run_problem(specs[k].build(), args)
            emit({"done": k})
        return
    for k, spec in enumerate(specs):
        run_problem(spec.build(), args)
        emit({"done": k})


if __name__ == "__main__":
    main()
