"""A/B of the compiled kernels across the build-system change (issue 17, "Benchmarks").

The kernels (``src/taskspace/_native/ik_kernel.cpp``, ``planning_kernel.cpp``) were compiled by
a hand-written ``build.py`` (g++ ``-O3 -march=native``) before merge 2fd8e57 and by
scikit-build-core + ``CMakeLists.txt`` (Release, portable unless ``TASKSPACE_NATIVE_ARCH``)
from it on. The C++ sources are the same; this script times the same scenes on each build.

Two modes:

* ``measure TREE``: in this process, import taskspace from ``TREE/src`` (the editable
  install's redirecting finder is removed from ``sys.meta_path`` and ``/work/main/src`` from
  ``sys.path`` first, and ``taskspace.__file__`` is checked), check that both kernels are
  loaded, and time
  (a) a compiled ``DifferentialIK`` step on the weighted Panda and G1 scenes of
  ``benchmarks/suites/ik.py`` (same tasks, limits, moving targets, dt; per step from the state
  update to the integrated configuration),
  (b) the compiled RRT-Connect (the planning suite's default options, fixed seeds) on a few
  MotionBenchMaker Panda problems, each repeated, and the compiled batch collision check;
  both as wall-clock time and as this thread's CPU time (``... cpu`` rows: on a loaded
  machine the wall-clock time of a plan also holds the time the process waited for a core).
  Prints one JSON object (min and median per item, plus checks and native-path flags).
* driver (default): runs ``measure`` for every ``--variant LABEL=TREE`` in separate
  subprocesses, ``--rounds`` times, rotating the order every round so that every build sees the
  same machine load; prints a table (per item: min, median of the round medians, spread of
  the round medians, and the new/old ratio per round) and writes
  ``benchmarks/results/build_change_ab.json`` (ignored by git).

Usage (worktrees built as described in the module's report)::

    .venv/bin/python benchmarks/build_change_ab.py --rounds 5 \
        --variant old=/tmp/ab-old --variant new=/tmp/ab-new --variant new-native=/tmp/ab-newnat
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
MAIN_SRC = HERE.parent / "src"
RESULTS = HERE / "results" / "build_change_ab.json"
DT = 0.005
G1_FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
G1_HANDS = ("left_rubber_hand", "right_rubber_hand")
MBM_ENV = "TASKSPACE_MOTIONBENCHMAKER_DIR"
MBM_DEFAULT = Path("/work/shared/benchmarks/motionbenchmaker_panda")
# (scenario, problem number, seed): valid problems on which seed 0 makes 700-6000 collision
# checks (the compiled planner solves them in a few to ~100 ms).
PROBLEMS = (
    ("bookshelf_small", 2, 0),
    ("bookshelf_tall", 2, 0),
    ("box", 6, 0),
    ("cage", 3, 0),
    ("table_under_pick", 4, 0),
)


# --------------------------------------------------------------------------- measure (child)


def isolate(tree: Path) -> Any:
    """Import taskspace from ``tree/src`` (not the editable install of /work/main)."""
    src = (tree / "src").resolve()
    if not (src / "taskspace" / "__init__.py").is_file():
        raise SystemExit(f"{src} holds no taskspace package")
    sys.meta_path[:] = [
        f
        for f in sys.meta_path
        if not type(f).__module__.startswith("_editable_skbc")
        and "ScikitBuild" not in type(f).__name__
    ]
    for name in [m for m in sys.modules if m == "taskspace" or m.startswith("taskspace.")]:
        del sys.modules[name]
    main_src = MAIN_SRC.resolve()
    sys.path[:] = [p for p in sys.path if not p or Path(p).resolve() != main_src]
    sys.path.insert(0, str(src))
    sys.path_importer_cache.clear()
    import taskspace

    where = Path(taskspace.__file__).resolve()
    if not where.is_relative_to(src):
        raise SystemExit(f"taskspace imported from {where}, not from {src}")
    return taskspace


def kernels_info(tree: Path) -> dict[str, Any]:
    """Which kernel files are loaded, and their build record (new builds only)."""
    from taskspace import _native

    ik, planning = _native.ik_kernel(), _native.planning_kernel()
    if ik is None or planning is None:
        raise SystemExit(f"kernels not used in {tree}: {_native.status()}")
    info: dict[str, Any] = {
        "ik_kernel": str(Path(str(ik.__file__)).resolve()),
        "planning_kernel": str(Path(str(planning.__file__)).resolve()),
        "status": _native.status(),
    }
    record = Path(info["ik_kernel"]).with_name("_build_info.json")
    if record.is_file():
        info["build_info"] = json.loads(record.read_text())
    for key in ("ik_kernel", "planning_kernel"):
        if not Path(info[key]).is_relative_to(tree.resolve()):
            raise SystemExit(f"{key} {info[key]} is not inside {tree}")
    return info


def _stats(samples: list[float]) -> dict[str, float]:
    import numpy as np

    a = np.asarray(samples)
    return {"min": float(a.min()), "median": float(np.median(a)), "n": int(a.size)}


def _ik_loop(robot: Any, ik: Any, moving: list[Any], steps: int) -> tuple[list[float], int]:
    """``steps`` steps of the scene; per-step times and how many ran in the kernel."""
    import numpy as np
    import pinocchio as pin

    state = robot.state(robot.q_default)
    q = robot.q_default.copy()
    times, native = [], 0
    for k in range(steps):
        off = np.array(
            [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
        )
        for task, T0 in moving:
            T = T0.copy()
            T.translation = T0.translation + off
            task.set_target(T)
        t0 = time.perf_counter()
        state.update(q)
        result = ik.solve(state, DT)
        q = pin.integrate(robot.model, q, result.dq)
        times.append(time.perf_counter() - t0)
        qp = getattr(result, "qp", None)
        native += int(qp is not None and getattr(qp, "backend", "") == "native")
    return times, native


def ik_scenes() -> dict[str, Any]:
    """The weighted Panda and G1 scenes of ``benchmarks/suites/ik.py`` (compiled kernel)."""
    from taskspace import features as F
    from taskspace.constraints import JointPositionLimits, JointVelocityLimits
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.model import Robot
    from taskspace.tasks import Task

    scenes = {}
    robot = Robot.load("panda")
    s = robot.state(robot.q_default)
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"), name="tcp")
    tcp.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot,
        [tcp, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=True),
    )
    scenes["ik panda step"] = (robot, ik, [(tcp, tcp.target.copy())])

    robot = Robot.load("g1")
    s = robot.state(robot.q_default)
    feet = [Task(F.FramePose(robot, f), name=f) for f in G1_FEET]
    hands = [Task(F.FramePose(robot, h), name=h) for h in G1_HANDS]
    com = [Task(F.CenterOfMass(robot), name="com")]
    for t in (*feet, *hands, *com):
        t.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    ik = DifferentialIK(
        robot,
        [*feet, *com, *hands, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=True),
    )
    scenes["ik g1 step"] = (robot, ik, [(t, t.target.copy()) for t in hands])
    return scenes


def measure_ik(steps: int, reps: int) -> dict[str, Any]:
    """Per-step times of each IK scene: ``reps`` runs of ``steps`` steps (first 10 dropped)."""
    out = {}
    for name, (robot, ik, moving) in ik_scenes().items():
        samples: list[float] = []
        native = total = 0
        for _ in range(reps):
            times, n = _ik_loop(robot, ik, moving, steps)
            samples += times[10:]
            native += n
            total += steps
        out[name] = {**_stats(samples), "unit": "us", "native_fraction": native / total}
    return out


def measure_planning(reps: int) -> dict[str, Any]:
    """Compiled RRT-Connect (planning suite defaults, 0.03 rad resolution) on :data:`PROBLEMS`."""
    import numpy as np

    from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
    from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
    from taskspace.planning.scene_loader import (
        motionbenchmaker_dir,
        motionbenchmaker_panda,
        motionbenchmaker_problems,
    )

    root = motionbenchmaker_dir()
    robot = motionbenchmaker_panda()
    out: dict[str, Any] = {}
    for scenario, index, seed in PROBLEMS:
        problem = motionbenchmaker_problems(root, scenario, [index])[0]
        req = problem.apply(robot)
        space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
        opts = RRTConnectOptions(
            step_size=0.5,
            coarse_resolution=0.15,
            local_sampling=0.5,
            trapped_priority=0.75,
            time_limit_s=10.0,
            seed=seed,
            native=True,
        )
        rrt_connect(space, req.start, req.goal, opts)  # warm-up: the kernel's world is built
        times, cpu, checks, ok, native = [], [], set(), True, True
        for _ in range(reps):
            c0 = time.thread_time()  # the kernel plans in this thread (GIL released)
            res = rrt_connect(space, req.start, req.goal, opts)
            cpu.append(time.thread_time() - c0)
            times.append(res.time_s)
            checks.add(int(res.collision_checks))
            ok &= bool(res.success)
            native &= res.log.get("native", 0.0) == 1.0
        facts = {"collision_checks": sorted(checks), "solved": ok, "native": native}
        out[f"rrt {scenario} #{index} s{seed}"] = {**_stats(times), "unit": "ms", **facts}
        out[f"rrt {scenario} #{index} s{seed} cpu"] = {**_stats(cpu), "unit": "ms", **facts}
    # the compiled batch collision check (scene of the last problem), per configuration
    checker: Any = space.checker
    kernel = checker.native_kernel()
    rng = np.random.default_rng(7)
    qs = np.array([robot.random_configuration(rng) for _ in range(2000)])
    kernel.collisions(qs[:100])
    per, per_cpu = [], []
    for _ in range(reps):
        t0, c0 = time.perf_counter(), time.thread_time()
        kernel.collisions(qs)
        per_cpu.append((time.thread_time() - c0) / len(qs))
        per.append((time.perf_counter() - t0) / len(qs))
    out["collision check (batch, per q)"] = {**_stats(per), "unit": "us", "native": True}
    out["collision check (batch, per q) cpu"] = {**_stats(per_cpu), "unit": "us", "native": True}
    return out


def measure(tree: Path, steps: int, ik_reps: int, plan_reps: int) -> dict[str, Any]:
    """Everything measured on one tree (the JSON printed by the ``measure`` mode)."""
    os.environ.setdefault(MBM_ENV, str(MBM_DEFAULT))
    taskspace = isolate(tree)
    info = kernels_info(tree)
    items = {**measure_ik(steps, ik_reps), **measure_planning(plan_reps)}
    return {
        "tree": str(tree),
        "taskspace_file": str(Path(taskspace.__file__).resolve()),
        "kernels": info,
        "items": items,
    }


# --------------------------------------------------------------------------- driver


def _run_child(tree: Path, args: argparse.Namespace) -> dict[str, Any]:
    cmd = [
        sys.executable,
        str(Path(__file__).resolve()),
        "measure",
        str(tree),
        "--steps",
        str(args.steps),
        "--ik-reps",
        str(args.ik_reps),
        "--plan-reps",
        str(args.plan_reps),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd="/tmp")
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _scale(unit: str) -> float:
    return {"us": 1e6, "ms": 1e3}[unit]


def summarize(runs: dict[str, list[dict[str, Any]]], base: str) -> dict[str, Any]:
    """Per item and variant: min, median of round medians, spread; ratios to ``base``."""
    import numpy as np

    labels = list(runs)
    items = list(runs[base][0]["items"])
    table: dict[str, Any] = {}
    for item in items:
        unit = runs[base][0]["items"][item]["unit"]
        s = _scale(unit)
        row: dict[str, Any] = {"unit": unit}
        for label in labels:
            meds = np.array([r["items"][item]["median"] for r in runs[label]]) * s
            mins = np.array([r["items"][item]["min"] for r in runs[label]]) * s
            row[label] = {
                "min": float(mins.min()),
                "median": float(np.median(meds)),
                "round_medians": meds.tolist(),
                "round_mins": mins.tolist(),
                "spread_pct": float((meds.max() - meds.min()) / np.median(meds) * 100),
            }
            extra = runs[label][0]["items"][item]
            for key in ("collision_checks", "native_fraction", "native", "solved"):
                if key in extra:
                    row[label][key] = extra[key]
            if label != base:
                base_meds = np.array([r["items"][item]["median"] for r in runs[base]]) * s
                paired = meds / base_meds  # same round: same machine window
                row[label]["ratio_median"] = float(np.median(meds) / np.median(base_meds))
                row[label]["ratio_min"] = float(mins.min() / row[base]["min"])
                row[label]["ratio_per_round"] = paired.tolist()
                row[label]["ratio_geomean_rounds"] = float(np.exp(np.log(paired).mean()))
                row[label]["rounds_slower"] = int((paired > 1.0).sum())
        table[item] = row
    return table


def print_table(table: dict[str, Any], labels: list[str], base: str) -> str:
    """The table as text (also returned)."""
    lines = []
    head = f"{'item':34s} {'unit':4s}"
    for label in labels:
        head += f" | {label + ' min':>14s} {label + ' med':>14s} {'spread':>7s}"
        if label != base:
            head += (
                f" {'ratio med':>9s} {'ratio min':>9s} {'per-round ratio range':>22s} {'>1':>5s}"
            )
    lines.append(head)
    lines.append("-" * len(head))
    for item, row in table.items():
        line = f"{item:34s} {row['unit']:4s}"
        for label in labels:
            c = row[label]
            line += f" | {c['min']:14.2f} {c['median']:14.2f} {c['spread_pct']:6.1f}%"
            if label != base:
                pr = c["ratio_per_round"]
                line += (
                    f" {c['ratio_median']:9.3f} {c['ratio_min']:9.3f}"
                    f" {min(pr):10.3f}..{max(pr):<10.3f} {c['rounds_slower']:>2d}/{len(pr):<2d}"
                )
        lines.append(line)
    lines.append(
        "min: least sample over all rounds; med: median of the round medians; spread: range of "
        "the round medians / med; ratio: variant / baseline; per-round ratio: of the medians of "
        "the same round; >1: rounds in which the variant was slower"
    )
    checks = [
        f"  {item}: " + ", ".join(f"{lb} {row[lb].get('collision_checks')}" for lb in labels)
        for item, row in table.items()
        if "collision_checks" in row[base] and not item.endswith(" cpu")
    ]
    if checks:
        lines.append("collision checks per plan (same seed; differ if floating point differs):")
        lines += checks
    text = "\n".join(lines)
    print(text)
    return text


def _loadavg() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def drive(args: argparse.Namespace) -> None:
    """Alternate the variants in subprocesses for ``args.rounds`` rounds."""
    variants = dict(v.split("=", 1) for v in args.variant)
    labels = list(variants)
    base = labels[0]
    started = dt.datetime.now(dt.timezone.utc)
    load0 = _loadavg()
    print(f"start {started:%Y-%m-%d %H:%M:%S} UTC, load average {load0}", flush=True)
    runs: dict[str, list[dict[str, Any]]] = {label: [] for label in labels}
    for r in range(args.rounds):
        order = labels[r % len(labels) :] + labels[: r % len(labels)]
        for label in order:
            t0 = time.perf_counter()
            out = _run_child(Path(variants[label]), args)
            out["round"] = r
            out["loadavg_after"] = _loadavg()
            runs[label].append(out)
            print(
                f"round {r + 1}/{args.rounds} {label:12s} {time.perf_counter() - t0:5.1f} s, "
                f"load {out['loadavg_after']}",
                flush=True,
            )
    finished = dt.datetime.now(dt.timezone.utc)
    for label in labels:
        k = runs[label][0]["kernels"]
        print(f"{label}: taskspace {runs[label][0]['taskspace_file']}")
        print(f"  kernels {k['ik_kernel']}, {k['planning_kernel']}")
        if "build_info" in k:
            print(f"  build_info {json.dumps(k['build_info'])}")
    table = summarize(runs, base)
    text = print_table(table, labels, base)
    print(f"end {finished:%Y-%m-%d %H:%M:%S} UTC, load average {_loadavg()}")
    result = {
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "started_utc": started.isoformat(),
        "finished_utc": finished.isoformat(),
        "loadavg_start": load0,
        "loadavg_end": _loadavg(),
        "variants": variants,
        "baseline": base,
        "settings": {"steps": args.steps, "ik_reps": args.ik_reps, "plan_reps": args.plan_reps},
        "table": table,
        "table_text": text,
        "runs": runs,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=1))
    print(f"wrote {RESULTS}")


def main(argv: list[str] | None = None) -> None:
    """Command-line entry point (see the module docstring)."""
    argv = sys.argv[1:] if argv is None else argv
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--steps", type=int, default=1500, help="IK steps per run")
    common.add_argument("--ik-reps", type=int, default=3, help="IK runs per scene")
    common.add_argument("--plan-reps", type=int, default=20, help="plans per problem")
    if argv[:1] == ["measure"]:
        p = argparse.ArgumentParser(parents=[common], description="time one source tree")
        p.add_argument("tree", type=Path)
        a = p.parse_args(argv[1:])
        out = measure(a.tree, a.steps, a.ik_reps, a.plan_reps)
        print(json.dumps(out))
        return
    p = argparse.ArgumentParser(parents=[common], description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument(
        "--variant",
        action="append",
        required=True,
        help="LABEL=TREE (the first is the baseline of the ratios)",
    )
    drive(p.parse_args(argv))


if __name__ == "__main__":
    main()
