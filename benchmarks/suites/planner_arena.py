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

Run: ``python -m benchmarks.run planner_arena [--quick]`` (table; the database and figures
go to the output directory too) or ``python -m benchmarks.suites.planner_arena [--quick]
[--out DIR]``. Environment: ``TASKSPACE_ARENA_DIR`` (output directory, default
``benchmarks/results/planner_arena``), ``TASKSPACE_ARENA_TIME`` (time limit [s]; 0.2 quick,
1 full), ``TASKSPACE_ARENA_SEEDS`` (runs per planner and problem; 2 quick, 3 full),
``TASKSPACE_ARENA_PROBLEMS`` (MotionBenchMaker problems per scenario, or ``all``; 2 quick,
all full), ``TASKSPACE_ARENA_SCENARIOS`` (comma-separated MotionBenchMaker scenarios; quick:
bookshelf_small and table_pick, full: all seven, 350 problems of which 313 are valid).

A progress bar (stderr) counts the problems, with its estimate of the time left. OMPL runs as
a server (``ompl_arena.py --serve``) fed one problem at a time after ours, and every problem's
runs are committed to the database when it ends: Ctrl-C (or a failing peer, whose runs then
stop) leaves a database of the problems finished, with both sides, table ``meta`` saying how
far the arena got (``status``: running, complete or interrupted; ``problems_done`` of
``problems_total``; the peer's note) and table ``planners`` listing every planner, OMPL's
missing from its bindings as "not available in OMPL <version>"; the table and figures are
then drawn from it.
"""

from __future__ import annotations

import argparse
import datetime
import functools
import json
import math
import os
import sqlite3
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import ROOT, Row, Timing, peer_python
from taskspace.errors import PlanningError
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerResult
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
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


_PANDA: list[Any] = []
"""The Panda of the MotionBenchMaker problems, loaded once per process (see below)."""


def motionbenchmaker_problem(scenario: str, index: int) -> Problem | None:
    """Problem ``index`` of a MotionBenchMaker ``scenario`` (``None``: invalid start or goal).

    Every problem is built on one Panda whose obstacles it replaces (each ``Robot.load``
    keeps about 70 MB for the life of the process: 350 robots would not fit in memory), so a
    problem is valid until the next one is built; the arena runs them one at a time.
    """
    if not _PANDA:
        _PANDA.append(motionbenchmaker_panda())
    robot = _PANDA[0]
    problem = motionbenchmaker_problems(motionbenchmaker_dir(), scenario, [index])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=RESOLUTION))
    try:
        space.check_endpoint(req.start, "start")
        space.check_endpoint(req.goal, "goal")
    except PlanningError:
        return None
    return Problem(f"mbm_{scenario}", index, space, req.start, req.goal)


@dataclass(frozen=True)
class ProblemSpec:
    """A problem of the arena, built when it is run (one at a time: see
    :func:`motionbenchmaker_problem`)."""

    scenario: str
    index: int
    make: Callable[[], Problem | None]

    def build(self) -> Problem | None:
        """The problem (``None``: not valid, skipped by both sides)."""
        return self.make()


def motionbenchmaker_specs(scenarios: list[str], count: int | None) -> list[ProblemSpec]:
    """Problems ``1..count`` (``None``: every one found) of each scenario, unbuilt."""
    try:
        root = motionbenchmaker_dir()
    except Exception:  # the data set is not on this machine
        return []
    out = []
    for scenario in scenarios:
        folder = next(
            (d for d in (root / f"{scenario}_panda", root / scenario) if d.is_dir()), None
        )
        if folder is None:
            continue
        found = sorted(int(f.stem[5:]) for f in folder.glob("scene*.yaml"))
        for index in found if count is None else [i for i in found if i <= count]:
            out.append(
                ProblemSpec(
                    f"mbm_{scenario}",
                    index,
                    functools.partial(motionbenchmaker_problem, scenario, index),
                )
            )
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
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS planners (planner TEXT PRIMARY KEY, available INTEGER, note TEXT);
"""


def set_meta(db: sqlite3.Connection, **values: Any) -> None:
    """Rows of ``meta`` (how far the arena got, its settings, the peer's state)."""
    db.executemany(
        "INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
        [(k, str(v)) for k, v in values.items()],
    )


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


def record_peer_run(db: sqlite3.Connection, date: str, r: dict[str, Any], optimum: float) -> None:
    """One row of ``runs`` (and its final cost in ``progress``) from an OMPL peer run."""
    ok = bool(r["success"])
    cur = db.execute(
        "INSERT INTO runs (date, planner, scenario, problem, seed, time_limit_s, success, "
        "status, time_s, cost, path_length, first_solution_s, collision_checks, optimum) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        (date, r["planner"], r["scenario"], r["problem"], r["seed"], r["time_limit_s"],
         int(ok), "solved" if ok else "not solved", r["time_s"], r["cost"] if ok else None,
         r["cost"] if ok else None, None, None, None if math.isnan(optimum) else optimum),
    )  # fmt: skip
    if ok:
        db.execute("INSERT INTO progress VALUES (?, ?, ?)", (cur.lastrowid, r["time_s"], r["cost"]))


class PeerError(RuntimeError):
    """The OMPL peer stopped or answered something else than its protocol."""


class OmplPeer:
    """``benchmarks/peers/ompl_arena.py --serve``: problems sent one at a time, runs read back.

    The peer runs in its own session (a Ctrl-C of the arena does not reach it; the arena
    closes it) with its stderr in a temporary file (its tail is the note of a failure).
    """

    def __init__(self, cmd: list[str]) -> None:
        env = dict(os.environ)
        env.pop("PYTHONPATH", None)
        self.errors = tempfile.TemporaryFile(mode="w+")
        self.proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.errors,
            text=True, env=env, start_new_session=True,
        )  # fmt: skip
        header = self._message()
        if header is None or "ompl_version" not in header:
            self.close()
            raise PeerError(f"the OMPL peer did not start: {self.stderr_tail()}")
        self.version = str(header["ompl_version"])
        self.planners: list[str] = list(header["planners"])
        self.missing: list[str] = list(header["missing"])

    def _message(self) -> dict[str, Any] | None:
        """The next JSON line of the peer (other lines skipped); ``None`` at its end."""
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            if line.startswith("{"):
                return dict(json.loads(line))
        return None

    def solve(self, k: int) -> Iterator[dict[str, Any]]:
        """The peer's runs on problem ``k`` of :func:`problem_specs`, as they come.

        Raises:
            PeerError: the peer stopped before finishing the problem.
        """
        assert self.proc.stdin is not None
        try:
            self.proc.stdin.write(json.dumps({"k": k}) + "\n")
            self.proc.stdin.flush()
        except OSError as exc:
            raise PeerError(f"the OMPL peer is gone ({exc}): {self.stderr_tail()}") from exc
        while True:
            msg = self._message()
            if msg is None:
                raise PeerError(f"the OMPL peer stopped in problem {k}: {self.stderr_tail()}")
            if "done" in msg:
                return
            yield msg["run"]

    def stderr_tail(self, chars: int = 300) -> str:
        """The end of what the peer wrote to stderr."""
        self.errors.seek(0)
        return " ".join(self.errors.read()[-chars:].split()) or "(no message)"

    def close(self) -> None:
        """End the peer (stdin closed: it exits; killed after 10 s)."""
        try:
            if self.proc.stdin is not None:
                self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()


def start_peer(quick: bool, limit: float, seeds: int) -> tuple[OmplPeer | None, str]:
    """The OMPL peer server, or ``None`` and the reason (not installed, failed to start)."""
    exe = peer_python("ompl")
    if exe is None:
        return None, "OMPL peer not installed (.venv-peers/ompl, make bench-peers)"
    args = ["--serve", "--time", str(limit), "--seeds", str(seeds)]
    args += ["--quick"] if quick else []
    if limit > CHECKPOINT_S:
        args += ["--checkpoint", str(CHECKPOINT_S)]
    try:
        return OmplPeer([str(exe), str(ROOT / "benchmarks/peers/ompl_arena.py"), *args]), ""
    except PeerError as exc:
        return None, f"OMPL peer failed: {exc}"


def record_planners(db: sqlite3.Connection, peer: OmplPeer | None) -> None:
    """Table ``planners``: ours, OMPL's that ran and OMPL's missing from its bindings."""
    rows = [(name, 1, "taskspace") for name in PLANNERS]
    rows += [(checkpoint_name(name, CHECKPOINT_S), 1, "taskspace") for name in CHECKPOINT_PLANNERS]
    if peer is not None:
        rows += [(name, 1, f"OMPL {peer.version}") for name in peer.planners]
        rows += [
            (f"ompl {name}", 0, f"not available in OMPL {peer.version}") for name in peer.missing
        ]
    db.executemany("INSERT OR REPLACE INTO planners VALUES (?, ?, ?)", rows)
    db.commit()


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


def arena(
    problems: Sequence[Problem | ProblemSpec],
    limit: float,
    seeds: int,
    db: sqlite3.Connection,
    *,
    peer: OmplPeer | None = None,
    progress: bool = False,
) -> list[str]:
    """Every planner on every problem with ``seeds`` seeds; rows into ``db``.

    RRT* and informed RRT* also run with the :data:`CHECKPOINT_S` budget (rows named by
    :func:`checkpoint_name`) when ``limit`` is longer: their cost after 0.1 s and after
    ``limit`` beside OMPL's (:func:`cost_rows`). With a ``peer`` (problems given as the
    :func:`problem_specs` list, whose positions it knows), OMPL's runs of each problem follow
    ours. Each problem's runs are committed when it ends and ``meta`` says how far the arena
    got: a Ctrl-C stops it there (the problem under way is dropped), a peer failure stops the
    peer's runs only, a planner raising leaves a row of status ``error``.

    Returns:
        Notes for the table (interrupted, peer failure, errors); empty when all went well.
    """
    from tqdm import tqdm

    date = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    notes: list[str] = []
    errors: list[str] = []
    done = skipped = 0
    set_meta(db, status="running", started=date, time_limit_s=limit, seeds=seeds,
             problems_total=len(problems), problems_done=0)  # fmt: skip
    db.commit()
    bar = tqdm(total=len(problems), desc="planner arena", unit="problem", disable=not progress,
               file=sys.stderr, dynamic_ncols=True)  # fmt: skip
    try:
        for k, item in enumerate(problems):
            p = item.build() if isinstance(item, ProblemSpec) else item
            bar.set_postfix_str(f"{item.scenario} {item.index}")
            if p is None:  # an invalid MotionBenchMaker problem: neither side runs it
                skipped += 1
                bar.update(1)
                continue
            jobs = [(name, name, limit) for name in PLANNERS]
            if limit > CHECKPOINT_S:
                jobs += [(checkpoint_name(n, CHECKPOINT_S), n, CHECKPOINT_S)
                         for n in CHECKPOINT_PLANNERS]  # fmt: skip
            raised: list[str] = []
            for label, name, budget in jobs:
                for seed in range(seeds):
                    t0 = time.perf_counter()
                    try:
                        res = PLANNERS[name](p, budget, seed)
                    except Exception as exc:  # a row says so; the arena goes on
                        raised.append(f"{label} on {p.scenario} {p.index}: {exc!r}")
                        db.execute(
                            "INSERT INTO runs (date, planner, scenario, problem, seed, "
                            "time_limit_s, success, status, time_s) "
                            "VALUES (?, ?, ?, ?, ?, ?, 0, 'error', ?)",
                            (date, label, p.scenario, p.index, seed, budget,
                             time.perf_counter() - t0),
                        )  # fmt: skip
                        continue
                    record(db, date, label, p, seed, budget, res)
            if peer is not None:
                try:
                    for r in peer.solve(k):
                        record_peer_run(db, date, r, p.optimum)
                except PeerError as exc:
                    notes.append(f"OMPL peer failed (its runs stop at problem {k}): {exc}")
                    set_meta(db, peer=notes[-1])
                    peer.close()
                    peer = None
            done += 1
            errors += raised
            set_meta(db, problems_done=done, problems_skipped=skipped)
            db.commit()
            bar.update(1)
    except KeyboardInterrupt:
        db.rollback()  # the problem under way: not all of its runs are in
        notes.append(f"interrupted (Ctrl-C) after {done + skipped} of {len(problems)} problems")
        set_meta(db, status="interrupted")
    else:
        set_meta(db, status="complete")
    finally:
        bar.close()
        if peer is not None:
            peer.close()
    if errors:
        notes.append(f"{len(errors)} runs raised (status 'error'), first: {errors[0]}")
    set_meta(db, finished=datetime.datetime.now(datetime.timezone.utc).isoformat(
        timespec="seconds"), notes=" | ".join(notes))  # fmt: skip
    db.commit()
    return notes


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


def _same(p: Problem) -> Problem:
    return p


def problem_specs(quick: bool) -> list[ProblemSpec]:
    """The arena's problems, unbuilt, in the order both sides run them.

    ``TASKSPACE_ARENA_PROBLEMS``: MotionBenchMaker problems per scenario (an integer or
    ``all``); ``TASKSPACE_ARENA_SCENARIOS``: their scenarios (comma-separated). The OMPL peer
    calls this too (same environment), so both sides plan the same problems.
    """
    default = "bookshelf_small,table_pick" if quick else ",".join(MOTIONBENCHMAKER_SCENARIOS)
    scenarios = [x for x in os.environ.get("TASKSPACE_ARENA_SCENARIOS", default).split(",") if x]
    unknown = sorted(set(scenarios) - set(MOTIONBENCHMAKER_SCENARIOS))
    if unknown:
        raise ValueError(
            f"TASKSPACE_ARENA_SCENARIOS: unknown {unknown}; scenarios are: "
            f"{', '.join(MOTIONBENCHMAKER_SCENARIOS)}"
        )
    count_in = os.environ.get("TASKSPACE_ARENA_PROBLEMS", "2" if quick else "all")
    count = None if count_in.strip().lower() == "all" else int(count_in)
    fixed = [
        ProblemSpec(p.scenario, p.index, functools.partial(_same, p))
        for p in square_2d() + panda_free() + talos_arm_torso()
    ]
    return fixed + motionbenchmaker_specs(scenarios, count)


def settings(quick: bool) -> tuple[float, int]:
    """``(time limit [s], seeds)`` from ``TASKSPACE_ARENA_TIME`` and ``TASKSPACE_ARENA_SEEDS``."""
    limit = float(os.environ.get("TASKSPACE_ARENA_TIME", "0.2" if quick else "1.0"))
    seeds = int(os.environ.get("TASKSPACE_ARENA_SEEDS", "2" if quick else "3"))
    return limit, seeds


def run(quick: bool, out: Path | None = None) -> list[Row]:
    """Run the arena; the database and figures go to ``out`` (or ``TASKSPACE_ARENA_DIR``)."""
    limit, seeds = settings(quick)
    out = out or Path(
        os.environ.get("TASKSPACE_ARENA_DIR", ROOT / "benchmarks/results/planner_arena")
    )
    out.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(out / "planner_arena.db")
    db.executescript(SCHEMA)
    for name in ("progress", "runs", "meta", "planners"):  # the database holds the latest arena
        db.execute(f"DELETE FROM {name}")
    specs = problem_specs(quick)
    peer, note = start_peer(quick, limit, seeds)
    if note:
        set_meta(db, peer=note)
    missing = [] if peer is None else [(name, peer.version) for name in peer.missing]
    record_planners(db, peer)
    notes = arena(specs, limit, seeds, db, peer=peer, progress=True)
    plot(db, out)
    rows = table(db) + cost_rows(db)
    db.close()
    rows += [
        Row(SUITE, "-", f"ompl {name}", None, note=f"not available in OMPL {version}")
        for name, version in missing
    ]
    rows += [Row(SUITE, "-", "arena", None, note=n) for n in ([note] if note else []) + notes]
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
