"""Planner arena (in the spirit of OMPL's Planner Arena): every planner on every scenario.

For each scenario and planner, several seeded runs within one time limit; each run becomes a
row of an SQLite database (``runs``: planner, scenario, problem, seed, success, time, cost,
first-solution time, checks, known optimum; ``progress``: the anytime planners' cost over
time). OMPL's planners run on the same problems with the same checker when their peer
environment is installed (``benchmarks/peers/ompl_arena.py``). Matplotlib figures show per
scenario the success rate, the time and the cost distributions (cost divided by the known
optimum where there is one) and the median cost over time. Scenarios: a 2-D square obstacle
(optimum known), the Panda in free space (optimum: the straight line), Talos's torso and
right arm with the rest of the humanoid locked (9 of 39 coordinates, over a shelf), and
MotionBenchMaker Panda problems (when the data set is present).

Run: ``python -m benchmarks.run planner_arena [--quick]`` (table) or
``python -m benchmarks.suites.planner_arena [--quick] [--out DIR]`` (table, database and
figures). Environment: ``TASKSPACE_ARENA_DIR`` (output directory, default
``benchmarks/results/planner_arena``), ``TASKSPACE_ARENA_TIME`` (time limit [s]),
``TASKSPACE_ARENA_SEEDS`` (runs per planner and problem; 2 quick, 10 full),
``TASKSPACE_ARENA_PROBLEMS`` (MotionBenchMaker problems per scenario; 2 quick, 5 full).
The full arena (23 problems x 10 seeds, 1 s limit) takes about an hour (13.5 s of wall time
per problem and seed in a reduced run, OMPL included).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sqlite3
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import ROOT, Row, Timing, run_peer
from taskspace.errors import PlanningError
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerResult
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from taskspace.planning.scene_loader import (
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)

SUITE = "planner_arena"
RESOLUTION = 0.03  # local-planner resolution of the Panda scenarios [rad]


# ----------------------------------------------------------------------------- scenes
class Problem:
    """One planning query: a space, start, goal and the known optimum (NaN if unknown)."""

    def __init__(
        self, scenario: str, index: int, space: ConfigurationSpace, start: Any, goal: Any,
        optimum: float = math.nan,
    ) -> None:  # fmt: skip
        self.scenario, self.index = scenario, index
        self.space, self.start, self.goal, self.optimum = space, start, goal, optimum


def square_2d() -> list[Problem]:
    """[0,1]^2 with the square [0.4,0.6]x[0.3,0.7]; optimum 2 sqrt(0.3^2 + 0.2^2) + 0.2."""

    def free(q: np.ndarray) -> np.ndarray:
        return ~((q[:, 0] > 0.4) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.7))

    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.005)
    )
    optimum = 2 * math.hypot(0.3, 0.2) + 0.2
    return [Problem("square_2d", 0, space, [0.1, 0.5], [0.9, 0.5], optimum)]


def panda_free() -> list[Problem]:
    """The Panda without obstacles; the straight line (checked free) is the optimum."""
    robot = motionbenchmaker_panda()
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=RESOLUTION))
    q0 = robot.q_default.copy()
    start, goal = q0.copy(), q0.copy()
    start[[0, 2, 3]] += [-2.0, -1.0, 0.6]
    goal[[0, 1, 2, 5]] += [2.0, 0.5, 1.0, 1.0]
    optimum = float(np.linalg.norm(goal - start))
    if not space.path_valid(np.stack([start, goal]), resolution=0.005):
        optimum = math.nan
    return [Problem("panda_free", 0, space, start, goal, optimum)]


TALOS_START = [0.454, 0.333, 0.793, -0.301, -1.613, -2.003, -1.914, -1.183, 0.048]
TALOS_GOAL = [1.016, -0.025, -0.263, -2.049, 0.421, -1.051, 1.568, 0.169, -0.295]


def talos_arm_torso() -> list[Problem]:
    """Talos's torso and right arm (9 dof; every other joint, the floating base included,
    locked at the default posture with ``locked_joints``) move the hand from under a shelf
    to above it (optimum unknown)."""
    from taskspace.model import Obstacle, Robot

    robot = Robot.load("talos", convex_collision=True)
    model = robot.model
    free = {"torso_1_joint", "torso_2_joint"} | {f"arm_right_{i}_joint" for i in range(1, 8)}
    q0 = robot.q_default
    locked = {
        str(model.names[j]): q0[model.joints[j].idx_q : model.joints[j].idx_q + model.joints[j].nq]
        for j in range(1, model.njoints)
        if str(model.names[j]) not in free
    }
    robot.add_obstacle(Obstacle.box("shelf", [0.5, 0.6, 0.04], [0.6, -0.35, 1.25]))
    space = ConfigurationSpace.from_robot(
        robot, locked_joints=locked, edge=EdgeCheckOptions(resolution=RESOLUTION)
    )
    return [Problem("talos_arm_torso", 0, space, TALOS_START, TALOS_GOAL)]


def motionbenchmaker(scenarios: list[str], count: int) -> list[Problem]:
    """The first ``count`` valid problems of each MotionBenchMaker scenario (optimum unknown)."""
    root = motionbenchmaker_dir()
    if not root.is_dir():
        return []
    out = []
    for scenario in scenarios:
        for index in range(1, count + 1):
            robot = motionbenchmaker_panda()
            problem = motionbenchmaker_problems(root, scenario, [index])[0]
            req = problem.apply(robot)
            space = ConfigurationSpace.from_robot(
                robot, edge=EdgeCheckOptions(resolution=RESOLUTION)
            )
            try:
                space.check_endpoint(req.start, "start")
                space.check_endpoint(req.goal, "goal")
            except PlanningError:
                continue
            out.append(Problem(f"mbm_{scenario}", index, space, req.start, req.goal))
    return out


# ----------------------------------------------------------------------------- planners
Planner = Callable[[Problem, float, int], PlannerResult]


def _tuple_result(res: Any) -> PlannerResult:
    return res[0] if isinstance(res, tuple) else res


PLANNERS: dict[str, Planner] = {
    "rrt_connect": lambda p, t, s: rrt_connect(
        p.space, p.start, p.goal, RRTConnectOptions(time_limit_s=t, seed=s)
    ),
    "rrt_star": lambda p, t, s: rrt_star(
        p.space, p.start, p.goal,
        RRTStarOptions(time_limit_s=t, max_iterations=None, informed=False, seed=s),
    ),
    "rrt_star_plain": lambda p, t, s: rrt_star(
        p.space, p.start, p.goal,
        RRTStarOptions(time_limit_s=t, max_iterations=None, informed=False, seed=s,
                       first_solution="rrt_star"),
    ),
    "informed_rrt_star": lambda p, t, s: rrt_star(
        p.space, p.start, p.goal, RRTStarOptions(time_limit_s=t, max_iterations=None, seed=s)
    ),
    "prm_star": lambda p, t, s: _tuple_result(
        prm_star(
            p.space, p.start, p.goal, PRMStarOptions(time_limit_s=t, max_iterations=None, seed=s)
        )
    ),
    "lazy_prm_star": lambda p, t, s: _tuple_result(
        lazy_prm_star(
            p.space, p.start, p.goal, PRMStarOptions(time_limit_s=t, max_iterations=None, seed=s)
        )
    ),
    "bit_star": lambda p, t, s: bit_star(
        p.space, p.start, p.goal, BITStarOptions(time_limit_s=t, max_iterations=None, seed=s)
    ),
}  # fmt: skip


# ----------------------------------------------------------------------------- database
SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY, date TEXT, planner TEXT, scenario TEXT, problem INTEGER,
    seed INTEGER, time_limit_s REAL, success INTEGER, status TEXT, time_s REAL, cost REAL,
    path_length REAL, first_solution_s REAL, collision_checks INTEGER, optimum REAL
);
CREATE TABLE IF NOT EXISTS progress (run_id INTEGER, t_s REAL, cost REAL);
"""


def record(db: sqlite3.Connection, date: str, planner: str, p: Problem, seed: int,
           limit: float, res: PlannerResult) -> None:  # fmt: skip
    """One row of ``runs`` (and the run's cost over time in ``progress``)."""
    cost = res.cost if res.cost is not None else res.path_length
    cur = db.execute(
        "INSERT INTO runs (date, planner, scenario, problem, seed, time_limit_s, success, "
        "status, time_s, cost, path_length, first_solution_s, collision_checks, optimum) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        (date, planner, p.scenario, p.index, seed, limit, int(res.success), res.status.value,
         res.time_s, cost if res.success else None, res.path_length if res.success else None,
         res.log.get("first_solution_s", res.time_s if res.success else None),
         res.collision_checks, None if math.isnan(p.optimum) else p.optimum),
    )  # fmt: skip
    times = res.log.get("cost_times") or ([res.time_s] if res.success else [])
    costs = res.log.get("costs") or ([cost] if res.success else [])
    db.executemany(
        "INSERT INTO progress VALUES (?, ?, ?)",
        [(cur.lastrowid, float(t), float(c)) for t, c in zip(times, costs)],
    )


def record_peers(db: sqlite3.Connection, problems: list[Problem], quick: bool, limit: float,
                 seeds: int) -> str:  # fmt: skip
    """OMPL's planners on the same problems (``benchmarks/peers/ompl_arena.py``) into ``db``.

    Returns a note ("" when the peer ran).
    """
    args = ["--time", str(limit), "--seeds", str(seeds)] + (["--quick"] if quick else [])
    if limit > CHECKPOINT_S:
        args += ["--checkpoint", str(CHECKPOINT_S)]
    try:
        out = run_peer("ompl", "ompl_arena.py", args)
    except RuntimeError as exc:
        return f"OMPL peer failed: {str(exc)[-300:]}"
    if out is None:
        return "OMPL peer not installed (.venv-peers/ompl, make bench-peers)"
    optimum = {p.scenario: p.optimum for p in problems}
    date = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    for r in out["runs"]:
        opt = optimum.get(r["scenario"], math.nan)
        ok = bool(r["success"])
        cur = db.execute(
            "INSERT INTO runs (date, planner, scenario, problem, seed, time_limit_s, success, "
            "status, time_s, cost, path_length, first_solution_s, collision_checks, optimum) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (date, r["planner"], r["scenario"], r["problem"], r["seed"],
             r.get("time_limit_s", limit), int(ok),
             "solved" if ok else "not solved", r["time_s"], r["cost"] if ok else None,
             r["cost"] if ok else None, None, None, None if math.isnan(opt) else opt),
        )  # fmt: skip
        if ok:
            db.execute(
                "INSERT INTO progress VALUES (?, ?, ?)", (cur.lastrowid, r["time_s"], r["cost"])
            )
    db.commit()
    return ""


CHECKPOINT_S = 0.1
"""Issue 22's short budget: RRT* and informed RRT* (ours and OMPL's) also run with this limit."""

CHECKPOINT_PLANNERS = ("rrt_star", "rrt_star_plain", "informed_rrt_star")
OMPL_NAMES = {
    "rrt_star": "ompl RRTstar",
    "rrt_star_plain": "ompl RRTstar",  # like for like: no RRT-Connect first solution
    "informed_rrt_star": "ompl InformedRRTstar",
}


def checkpoint_name(planner: str, limit: float) -> str:
    """Name of the runs of ``planner`` with the short budget ``limit`` (e.g. ``rrt_star@0.1s``)."""
    return f"{planner}@{limit:g}s"


def arena(problems: list[Problem], limit: float, seeds: int, db: sqlite3.Connection) -> None:
    """Every planner on every problem with ``seeds`` seeds; rows into ``db``.

    RRT* and informed RRT* also run with the :data:`CHECKPOINT_S` budget (rows named by
    :func:`checkpoint_name`) when ``limit`` is longer: their cost after 0.1 s and after
    ``limit`` beside OMPL's (:func:`cost_rows`).
    """
    date = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    for p in problems:
        for name, plan in PLANNERS.items():
            for seed in range(seeds):
                record(db, date, name, p, seed, limit, plan(p, limit, seed))
        if limit > CHECKPOINT_S:
            for name in CHECKPOINT_PLANNERS:
                short = checkpoint_name(name, CHECKPOINT_S)
                for seed in range(seeds):
                    res = PLANNERS[name](p, CHECKPOINT_S, seed)
                    record(db, date, short, p, seed, CHECKPOINT_S, res)
    db.commit()


def cost_rows(db: sqlite3.Connection) -> list[Row]:
    """RRT* and informed RRT*: success and median cost after each budget, ours beside OMPL's.

    One row per scenario, planner and budget (the arena's limit and :data:`CHECKPOINT_S`):
    ``success`` and ``median_cost`` of ours and of OMPL's planner on the same problems and
    seeds, and ``cost_ratio`` = our median cost / OMPL's (over the runs both solved: the
    median over problems of the per-problem median ratio; < 1: ours is cheaper).
    """
    rows = []
    scenarios = [r[0] for r in db.execute("SELECT DISTINCT scenario FROM runs ORDER BY scenario")]
    limits = sorted(
        {r[0] for r in db.execute("SELECT DISTINCT time_limit_s FROM runs")}, reverse=True
    )
    for scenario in scenarios:
        for planner in CHECKPOINT_PLANNERS:
            for limit in limits:
                short = not math.isclose(limit, max(limits))
                ours = checkpoint_name(planner, limit) if short else planner
                peer = checkpoint_name(OMPL_NAMES[planner], limit) if short else OMPL_NAMES[planner]
                a, b = _costs(db, scenario, ours), _costs(db, scenario, peer)
                if not a:
                    continue
                extra: dict[str, Any] = {"budget_s": limit, **_summary(a, "")}
                if b:
                    extra.update(_summary(b, "ompl_"))
                    ratios = [
                        float(np.median([c for c in a[k] if c is not None]))
                        / float(np.median([c for c in b[k] if c is not None]))
                        for k in a
                        if k in b
                        and any(c is not None for c in a[k])
                        and any(c is not None for c in b[k])
                    ]
                    if ratios:
                        extra["cost_ratio"] = round(float(np.median(ratios)), 4)
                note = "" if b else "OMPL's runs missing (peer not installed or failed)"
                rows.append(
                    Row(SUITE, scenario, f"{planner} cost after {limit:g} s", None, extra,
                        note=note)
                )  # fmt: skip
    return rows


def _costs(db: sqlite3.Connection, scenario: str, planner: str) -> dict[int, list[float | None]]:
    """Costs (``None``: not solved) of each problem's runs."""
    out: dict[int, list[float | None]] = {}
    for problem, success, cost in db.execute(
        "SELECT problem, success, cost FROM runs WHERE scenario = ? AND planner = ?",
        (scenario, planner),
    ):
        out.setdefault(int(problem), []).append(float(cost) if success else None)
    return out


def _summary(costs: dict[int, list[float | None]], prefix: str) -> dict[str, Any]:
    flat = [c for runs in costs.values() for c in runs]
    solved = [c for c in flat if c is not None]
    summary: dict[str, Any] = {f"{prefix}success": round(len(solved) / len(flat), 4)}
    if solved:
        summary[f"{prefix}median_cost"] = round(float(np.median(solved)), 4)
    return summary


def plot(db: sqlite3.Connection, out: Path) -> list[Path]:
    """One figure per scenario: success, time, cost (/ optimum) and median cost over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    scenarios = [r[0] for r in db.execute("SELECT DISTINCT scenario FROM runs ORDER BY scenario")]
    for scenario in scenarios:
        rows = db.execute(
            "SELECT id, planner, success, time_s, cost, optimum FROM runs WHERE scenario = ?",
            (scenario,),
        ).fetchall()
        planners = list(dict.fromkeys(r[1] for r in rows))
        fig, axes = plt.subplots(1, 4, figsize=(20, 4.8))
        success = [np.mean([r[2] for r in rows if r[1] == pl]) for pl in planners]
        axes[0].bar(planners, success)
        axes[0].set_ylim(0, 1.05)
        axes[0].set_title("success rate")
        axes[1].boxplot(
            [[r[3] for r in rows if r[1] == pl] for pl in planners], tick_labels=planners
        )
        axes[1].set_title("time [s]")
        norm = [
            [r[4] / r[5] if r[5] else r[4] for r in rows if r[1] == pl and r[2]] or [np.nan]
            for pl in planners
        ]
        axes[2].boxplot(norm, tick_labels=planners)
        known = rows[0][5] is not None
        axes[2].set_title("cost / optimum" if known else "cost")
        for pl in planners:
            ids = [r[0] for r in rows if r[1] == pl]
            grid = np.linspace(0, max(r[3] for r in rows), 50)
            curves = []
            for i in ids:
                prog = db.execute(
                    "SELECT t_s, cost FROM progress WHERE run_id = ?", (i,)
                ).fetchall()
                curve = np.full(grid.size, np.nan)
                for t, c in prog:
                    curve[grid >= t] = c
                curves.append(curve)
            scale = rows[0][5] or 1.0
            with warnings.catch_warnings():  # all-NaN columns: no solution yet at that time
                warnings.simplefilter("ignore", RuntimeWarning)
                median = np.nanmedian(np.array(curves), axis=0) / scale
                style = "--" if pl.startswith("ompl") else "-"  # 17 curves, 10 colours
                axes[3].plot(grid, median, style, label=pl)
        axes[3].set_title("median best cost" + (" / optimum" if known else "") + " over time")
        axes[3].set_xlabel("t [s]")
        axes[3].legend(
            fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0)
        )  # not on the curves
        for ax in axes[:3]:
            ax.tick_params(axis="x", labelrotation=60, labelsize=7)
            for label in ax.get_xticklabels():
                label.set_horizontalalignment("right")  # the label ends under its bar or box
        fig.suptitle(scenario)
        fig.tight_layout()
        path = out / f"{scenario}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        files.append(path)
    return files


def table(db: sqlite3.Connection) -> list[Row]:
    """Benchmark rows: per scenario and planner, time distribution, success, median cost."""
    rows = []
    keys = db.execute("SELECT DISTINCT scenario, planner FROM runs ORDER BY scenario").fetchall()
    for scenario, planner in keys:
        runs = db.execute(
            "SELECT success, time_s, cost, optimum, first_solution_s FROM runs "
            "WHERE scenario = ? AND planner = ?",
            (scenario, planner),
        ).fetchall()
        ok = [r for r in runs if r[0]]
        extra: dict[str, Any] = {"runs": len(runs), "success": len(ok) / len(runs)}
        if ok:
            extra["median_cost"] = float(np.median([r[2] for r in ok]))
            first = [r[4] for r in ok if r[4] is not None]
            if first:
                extra["median_first_s"] = float(np.median(first))
            if ok[0][3]:
                extra["median_cost/optimum"] = float(np.median([r[2] / r[3] for r in ok]))
        timing = Timing.from_samples([r[1] for r in runs])
        rows.append(Row(SUITE, scenario, planner, timing, extra, ratio_to="rrt_connect"))
    return rows


def _problems(quick: bool) -> list[Problem]:
    """The arena's problems (``TASKSPACE_ARENA_PROBLEMS``: MotionBenchMaker ones per scenario).

    The OMPL peer calls this too (same environment), so both sides plan the same problems.
    """
    scen = ["bookshelf_small", "table_pick"] if quick else ["bookshelf_small", "box", "cage",
                                                            "table_pick"]  # fmt: skip
    count = int(os.environ.get("TASKSPACE_ARENA_PROBLEMS", "2" if quick else "5"))
    return square_2d() + panda_free() + talos_arm_torso() + motionbenchmaker(scen, count)


def run(quick: bool, out: Path | None = None) -> list[Row]:
    """Run the arena; the database and figures go to ``out`` (or ``TASKSPACE_ARENA_DIR``)."""
    limit = float(os.environ.get("TASKSPACE_ARENA_TIME", "0.2" if quick else "1.0"))
    seeds = int(os.environ.get("TASKSPACE_ARENA_SEEDS", "2" if quick else "10"))
    out = out or Path(
        os.environ.get("TASKSPACE_ARENA_DIR", ROOT / "benchmarks/results/planner_arena")
    )
    out.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(out / "planner_arena.db")
    db.executescript(SCHEMA)
    db.execute("DELETE FROM progress")  # the database holds the latest arena
    db.execute("DELETE FROM runs")
    problems = _problems(quick)
    arena(problems, limit, seeds, db)
    note = record_peers(db, problems, quick, limit, seeds)
    plot(db, out)
    rows = table(db) + cost_rows(db)
    db.close()
    if note:
        rows.append(Row(SUITE, "-", "ompl", None, note=note))
    return rows


def main() -> None:
    """``python -m benchmarks.suites.planner_arena [--quick] [--out DIR]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    for row in run(args.quick, args.out):
        t = row.timing
        ms = t.median_us / 1e3 if t else math.nan
        print(f"{row.scene:24s} {row.method:18s} median {ms:8.1f} ms {json.dumps(row.extra)}")


if __name__ == "__main__":
    main()
