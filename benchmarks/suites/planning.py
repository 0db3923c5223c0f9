"""Sampling-based planning suite: MotionBenchMaker Panda problems (7 scenarios x 50).

Scenes (obstacle worlds, start/goal) are loaded before timing. For every problem: is it valid
(start and goal inside the limits and collision-free for example-robot-data's Panda, fingers
locked open, convex-hull collision geometry)? Then RRT-Connect (1 s limit), Lazy PRM (1 s
limit, 300 nodes) and, in the quick run only, PRM (200 nodes, k = 8; roadmap built per
problem). Peers in the same run: OMPL's RRTConnect calling OUR collision checker as its
validity callback (same resolution, same range), and pyroboplan's RRT-Connect.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, run_peer
from taskspace.errors import PlanningError
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm_query
from taskspace.planning.prm import PRMOptions, prm
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.shortcut import shortcut_path

SUITE = "planning"
ROOT = Path("/work/shared/benchmarks/motionbenchmaker_panda")
RESOLUTION = 0.03  # local-planner resolution delta [rad], shared with the OMPL peer
STEP_SIZE = 1.0  # RRT-Connect range alpha [rad], shared with the OMPL peer
TIME_LIMIT = 1.0  # [s]


def problem_indices(quick: bool) -> list[int]:
    """Problem numbers per scenario (quick: the first five)."""
    return list(range(1, 6)) if quick else list(range(1, 51))


def _checker_cost(robot: Any, scenario: str, rng: np.random.Generator) -> dict[str, float]:
    """Per-configuration cost of the collision check on random configurations [us]."""
    checker = CollisionChecker(robot)
    qs = np.array([robot.random_configuration(rng) for _ in range(2000)])
    checker.are_valid(qs[:100])
    t0 = time.perf_counter()
    free = checker.are_valid(qs)
    batch = (time.perf_counter() - t0) / len(qs)
    t0 = time.perf_counter()
    for q in qs[:500]:
        checker.is_valid(q)
    single = (time.perf_counter() - t0) / 500
    return {"batch_us": batch * 1e6, "single_us": single * 1e6, "free_fraction": float(free.mean())}


def _summary(times: list[float], extra: dict[str, Any]) -> tuple[Timing | None, dict[str, Any]]:
    timing = Timing.from_samples(times) if times else None
    return timing, extra


def run(quick: bool) -> list[Row]:
    rows: list[Row] = []
    if not ROOT.is_dir():
        return [Row(SUITE, "motionbenchmaker", "taskspace", None, note=f"{ROOT} missing")]
    robot = motionbenchmaker_panda()
    indices = problem_indices(quick)
    rng = np.random.default_rng(0)
    edge = EdgeCheckOptions(resolution=RESOLUTION)
    ours: dict[str, dict[str, Any]] = {}
    for scenario in MOTIONBENCHMAKER_SCENARIOS:
        problems = motionbenchmaker_problems(ROOT, scenario, indices)
        stats: dict[str, dict[str, list[float]]] = {
            m: {"time": [], "ok": [], "checks": [], "length": []}
            for m in ("rrt_connect", "lazy_prm", "prm")
        }
        valid = 0
        invalid_reasons: list[str] = []
        cost: dict[str, float] = {}
        for k, problem in enumerate(problems):
            req = problem.apply(robot)
            space = ConfigurationSpace.from_robot(robot, edge=edge)
            if k == 0:
                cost = _checker_cost(robot, scenario, rng)
            try:
                space.check_endpoint(req.start, "start")
                space.check_endpoint(req.goal, "goal")
            except PlanningError as exc:
                invalid_reasons.append(f"{problem.index}: {str(exc)[:80]}")
                continue
            valid += 1
            res = rrt_connect(
                space,
                req.start,
                req.goal,
                RRTConnectOptions(step_size=STEP_SIZE, time_limit_s=TIME_LIMIT, seed=k),
            )
            s = stats["rrt_connect"]
            s["time"].append(res.time_s)
            s["ok"].append(float(res.success and res.time_s <= TIME_LIMIT))
            s["checks"].append(res.collision_checks)
            if res.success:
                s["length"].append(shortcut_path(space, res.path).length_after)
            t0 = time.perf_counter()
            lazy = build_lazy_prm(space, PRMOptions(n_samples=300, k_neighbors=10, seed=k))
            lres = lazy_prm_query(
                space,
                lazy,
                req.start,
                req.goal,
                PRMOptions(k_neighbors=10),
                time_limit_s=TIME_LIMIT,
            )
            lt = time.perf_counter() - t0
            s = stats["lazy_prm"]
            s["time"].append(lt)
            s["ok"].append(float(lres.success and lt <= TIME_LIMIT))
            s["checks"].append(lres.collision_checks + lazy.roadmap.collision_checks)
            if lres.success:
                s["length"].append(lres.path_length)
            if quick and k < 2:
                pres, _ = prm(
                    space, req.start, req.goal, PRMOptions(n_samples=200, k_neighbors=8, seed=k)
                )
                s = stats["prm"]
                s["time"].append(pres.time_s)
                s["ok"].append(float(pres.success and pres.time_s <= TIME_LIMIT))
                s["checks"].append(pres.collision_checks)
                if pres.success:
                    s["length"].append(pres.path_length)
        for method, s in stats.items():
            if not s["time"]:
                continue
            extra = {
                "problems": len(problems),
                "valid": valid,
                "solved_1s": int(sum(s["ok"])),
                "success_rate": float(np.mean(s["ok"])),
                "median_ms": float(np.median(s["time"]) * 1e3),
                "p95_ms": float(np.percentile(s["time"], 95) * 1e3),
                "median_checks": float(np.median(s["checks"])),
                "median_path_length_rad": float(np.median(s["length"])) if s["length"] else None,
            }
            if method == "rrt_connect":
                extra.update({f"check_{k}": v for k, v in cost.items()})
                extra["invalid"] = invalid_reasons
                ours[scenario] = extra
            timing, extra = _summary(s["time"], extra)
            rows.append(Row(SUITE, scenario, f"taskspace {method}", timing, extra))

    args = ["--quick"] if quick else []
    args += ["--resolution", str(RESOLUTION), "--range", str(STEP_SIZE), "--time", str(TIME_LIMIT)]
    for peer, script, label in (
        ("ompl", "ompl_planning.py", "ompl RRTConnect (our checker)"),
        ("pyroboplan", "pyroboplan_planning.py", "pyroboplan RRTConnect"),
    ):
        try:
            out = run_peer(peer, script, args, timeout=7200)
        except Exception as exc:  # a failing peer must not kill the suite
            rows.append(Row(SUITE, "all", label, None, note=f"peer failed: {str(exc)[-300:]}"))
            continue
        if out is None:
            rows.append(
                Row(SUITE, "all", label, None, note=f"peer venv .venv-peers/{peer} missing")
            )
            continue
        for scenario, res in out["scenarios"].items():
            times = res["times"]
            extra = {
                "valid": res["valid"],
                "solved_1s": res["solved"],
                "success_rate": res["solved"] / max(1, res["valid"]),
                "median_ms": float(np.median(times) * 1e3) if times else None,
                "median_checks": res.get("median_checks"),
            }
            mine = ours.get(scenario)
            if mine and extra["median_ms"]:
                extra["ratio_median_taskspace_over_peer"] = mine["median_ms"] / extra["median_ms"]
            rows.append(
                Row(
                    SUITE,
                    scenario,
                    label,
                    Timing.from_samples(times) if times else None,
                    extra,
                    ratio_to="taskspace rrt_connect",
                    note=out.get("note", ""),
                )
            )
    return rows
