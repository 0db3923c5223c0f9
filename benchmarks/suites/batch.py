"""Batch work through ``taskspace.batch``: backends, per-task overhead, campaigns, datasets.

* ``overhead``: CPU-bound tasks of 10 ms on 2 workers, one task per chunk, against a plain
  ``multiprocessing.Pool`` (same start method, chunksize 1), pool start-up included in both;
  the overhead is the wall time over the ideal ``n * 10 ms / workers``. ``ROUNDS`` rounds,
  the methods alternating within each; the overheads are of the fastest round (``overhead``,
  ``vs_plain``) and of the median one (``..._median``).
* ``per_task``: tiny tasks, one per chunk: what each backend costs per task (Ray's runtime
  start-up excluded, reported apart); ``ROUNDS`` rounds alternating, the table's median.
* ``mbm_campaign``: the MotionBenchMaker Panda problems x 3 seeds (compiled and Python
  RRT-Connect on each), serially and on 2 workers: wall time and speed-up. Each backend gets a
  new executor inside the timed region: worker start-up (processes or Ray actors; not the Ray
  runtime, started before) and the scene load are counted for every backend, serial included
  (each run's context has a key of its own, so no process reuses a scene built before).
  ``mbm_campaign warm``: the same campaign again on the same executor right after, so every
  backend has its workers started and its scene built before the timing (serial: the
  driver's scene); ``startup_s`` is the median of cold minus warm.
  ``TASKSPACE_BATCH_CAMPAIGN_ROUNDS`` rounds (default 1; about 3.5 minutes each), the backends
  alternating; the speed-ups are of the fastest runs (``speedup_over_serial``) and of the
  medians.

Every row carries ``load1``, the 1-minute load average when it was measured (this machine
has 2 cores; numbers taken above a load of about 2 are not comparable).
* ``ik_dataset``: ``learning.ik_dataset`` on random reachable Panda poses: poses per second
  per core. Each backend's executor is warmed first by a small dataset (workers started, robot
  loaded; its time is the ``startup_s`` column), the same way for serial, processes and Ray;
  the timed run reuses it.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, run_peer
from benchmarks.suites import _batch_tasks as T
from taskspace.batch import BatchOptions, Executor, write_sqlite

SUITE = "batch"
WORKERS = 2
ROUNDS = 3
"""Rounds of the cheap rows (overhead, per task), the methods alternating in each."""


def _load() -> float:
    """The 1-minute load average (the machine's other work, which these timings share)."""
    return round(os.getloadavg()[0], 2)


def _wall(fn: Any) -> tuple[float, Any]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _ray_ready() -> float | None:
    """Start a local Ray runtime; its start-up time [s] (None when Ray is missing)."""
    try:
        import ray
    except ImportError:
        return None
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    path = os.environ.get("PYTHONPATH", "")  # workers import what the driver imports
    t0 = time.perf_counter()
    if not ray.is_initialized():
        # Through the environment, as taskspace.batch does (not a runtime_env): the workers
        # Ray starts with the runtime then serve the executors' actors.
        os.environ["PYTHONPATH"] = f"{here}{os.pathsep}{path}"
        try:
            ray.init(num_cpus=WORKERS, include_dashboard=False, log_to_driver=False)
        finally:
            if path:
                os.environ["PYTHONPATH"] = path
            else:
                os.environ.pop("PYTHONPATH", None)
    return time.perf_counter() - t0


def _overhead(quick: bool, ray_ok: bool) -> list[Row]:
    n, seconds = (40, 0.01) if quick else (400, 0.01)
    items = [seconds] * n
    ideal = n * seconds / WORKERS
    ctx = multiprocessing.get_context("forkserver")

    def plain() -> Any:
        with ctx.Pool(WORKERS) as pool:
            return pool.map(T.spin_plain, items, chunksize=1)

    def ours(backend: str) -> Any:
        opts = BatchOptions(backend=backend, workers=WORKERS, chunk_size=1, progress=False)  # type: ignore[arg-type]
        with Executor(opts) as ex:
            result = ex.map(T.spin, items)
        assert result.success
        return result

    methods: dict[str, Any] = {"multiprocessing.Pool": plain}
    methods["taskspace processes"] = lambda: ours("processes")
    if ray_ok:
        methods["taskspace ray"] = lambda: ours("ray")
    times: dict[str, list[float]] = {name: [] for name in methods}
    load = _load()
    for _ in range(ROUNDS):
        for name, fn in methods.items():
            times[name].append(_wall(fn)[0])
    plain_min, plain_med = (
        min(times["multiprocessing.Pool"]),
        float(np.median(times["multiprocessing.Pool"])),
    )
    rows = []
    for name, samples in times.items():
        t_min, t_med = min(samples), float(np.median(samples))
        extra: dict[str, Any] = {
            "tasks": n,
            "rounds": len(samples),
            "overhead": t_min / ideal - 1,
            "overhead_median": t_med / ideal - 1,
            "load1": load,
        }
        if name != "multiprocessing.Pool":
            extra["vs_plain"] = t_min / plain_min - 1
            extra["vs_plain_median"] = t_med / plain_med - 1
        rows.append(
            Row(
                SUITE,
                "overhead 10 ms tasks",
                name,
                Timing.from_samples(np.asarray(samples) / n),
                extra,
                ratio_to=None if name == "multiprocessing.Pool" else "multiprocessing.Pool",
            )
        )
    dask = run_peer("dask", "dask_batch.py", [str(n), str(seconds), "20"])
    rows.insert(
        1,
        Row(
            SUITE,
            "overhead 10 ms tasks",
            "dask.distributed (LocalCluster)",
            Timing.from_samples([dask["overhead"] / n]) if dask else None,
            {
                "tasks": n,
                "overhead": dask["overhead"] / ideal - 1,
                "startup_s": dask["startup"],
                "load1": load,
            }
            if dask
            else {},
            ratio_to="multiprocessing.Pool",
            note="" if dask else "peer not installed (make bench-peers)",
        ),
    )
    return rows


def _per_task(quick: bool, ray_ok: bool) -> list[Row]:
    n = 200 if quick else 2000
    backends = ["serial", "processes"] + (["ray"] if ray_ok else [])
    executors = {
        b: Executor(BatchOptions(backend=b, workers=WORKERS, chunk_size=1, progress=False))  # type: ignore[arg-type]
        for b in backends
    }
    times: dict[str, list[float]] = {b: [] for b in backends}
    load = _load()
    try:
        for ex in executors.values():
            ex.map(T.noop, range(20))  # warm: pools, imports
        for _ in range(ROUNDS):
            for b, ex in executors.items():
                t, result = _wall(lambda ex=ex: ex.map(T.noop, range(n)))
                assert result.success
                times[b].append(t / n)
    finally:
        for ex in executors.values():
            ex.close()
    rows = [
        Row(
            SUITE,
            "per task (no-op)",
            f"taskspace {b}",
            Timing.from_samples(times[b]),
            {"tasks": n, "rounds": ROUNDS, "min_us": min(times[b]) * 1e6, "load1": load},
            ratio_to="taskspace serial",
        )
        for b in backends
    ]
    dask = run_peer("dask", "dask_batch.py", ["4", "0.01", str(n)])
    rows.append(
        Row(
            SUITE,
            "per task (no-op)",
            "dask.distributed",
            Timing.from_samples([dask["per_task"] / n]) if dask else None,
            {"tasks": n, "load1": load},
            ratio_to="taskspace serial",
            note="" if dask else "peer not installed (make bench-peers)",
        )
    )
    return rows


def _campaign_db() -> Path:
    """A fresh database for the campaign's runs (``out/`` beside the benchmarks)."""
    path = Path(__file__).resolve().parents[2] / "out" / "mbm_campaign.sqlite"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.unlink(missing_ok=True)
    return path


def _campaign(quick: bool, ray_ok: bool) -> list[Row]:
    from taskspace.errors import ModelLoadError
    from taskspace.planning.scene_loader import MOTIONBENCHMAKER_SCENARIOS, motionbenchmaker_dir

    try:
        motionbenchmaker_dir()
    except ModelLoadError:
        return [Row(SUITE, "mbm_campaign", "taskspace", None, note="MotionBenchMaker data missing")]
    scenarios = list(MOTIONBENCHMAKER_SCENARIOS)[:2] if quick else list(MOTIONBENCHMAKER_SCENARIOS)
    problems = range(1, 6 if quick else 51)
    items = [(s, p, seed) for s in scenarios for p in problems for seed in range(3)]
    rounds = int(os.environ.get("TASKSPACE_BATCH_CAMPAIGN_ROUNDS", "1"))
    backends = ["serial", "processes"] + (["ray"] if ray_ok else [])
    # per mode and backend: (wall time, result, load) of each round
    runs: dict[str, dict[str, list[tuple[float, Any, float]]]] = {
        mode: {b: [] for b in backends} for mode in ("cold", "warm")
    }
    db: Path | None = None
    for r in range(rounds):
        for backend in backends:
            opts = BatchOptions(backend=backend, workers=WORKERS, progress=False)  # type: ignore[arg-type]
            # A context key of its own: even serial builds its scene inside the cold timing
            # (this process keeps the last context it built, e.g. by an earlier round).
            context = functools.partial(T.mbm_context, (backend, r))
            with Executor(opts) as ex:
                for mode in ("cold", "warm"):  # warm: the same executor again
                    load = _load()
                    t, result = _wall(lambda ex=ex, c=context: ex.map(T.mbm_plan, items, context=c))
                    runs[mode][backend].append((t, result, load))
            if db is None:
                # One row per run, OMPL-style (planner columns compiled.* and python.*).
                db = write_sqlite(result, _campaign_db(), experiment="mbm_campaign")
    reference = runs["cold"]["serial"][0][1].values
    rows = []
    for mode, by_backend in runs.items():
        serial_times = [t for t, _, _ in by_backend["serial"]]
        for backend in backends:
            samples = [t for t, _, _ in by_backend[backend]]
            t, result, _ = min(by_backend[backend], key=lambda run: run[0])
            values = result.values
            solved = [v["compiled"]["solved"] for v in values if v["valid"]]
            py_time = float(np.median([v["python"]["time_s"] for v in values if v["valid"]]))
            extra: dict[str, Any] = {
                "runs": len(items),
                "valid": len(solved),
                "solved": int(sum(solved)),
                "median_python_plan_ms": py_time * 1e3,
                "chunk_size": result.chunk_size,
                "rounds": rounds,
                "load1": [load for _, _, load in by_backend[backend]],
                "database": str(db),
            }
            if mode == "warm":
                cold = [c for c, _, _ in runs["cold"][backend]]
                extra["startup_s"] = float(np.median(np.subtract(cold, samples)))
            if backend != "serial":
                extra["speedup_over_serial"] = min(serial_times) / t
                extra["speedup_median"] = float(np.median(serial_times) / np.median(samples))
                same = [
                    a["compiled"]["solved"] == b["compiled"]["solved"]
                    for a, b in zip(values, reference)
                    if a["valid"] and b["valid"]  # invalid problems (start or goal in collision)
                ]
                extra["same_success_as_serial"] = float(np.mean(same))
            rows.append(
                Row(
                    SUITE,
                    "mbm_campaign" if mode == "cold" else "mbm_campaign warm",
                    f"taskspace {backend}",
                    Timing.from_samples(samples),
                    extra,
                    ratio_to="taskspace serial",
                )
            )
    return rows


def _ik_dataset(quick: bool, ray_ok: bool) -> list[Row]:
    from taskspace.learning.ik_dataset import ik_dataset, sample_reachable_poses
    from taskspace.model import Robot

    n = int(os.environ.get("TASKSPACE_IK_DATASET_POSES", "400" if quick else "100000"))
    poses = sample_reachable_poses(Robot.load("panda"), n, np.random.default_rng(0))
    rows = []
    backends = [("serial", 1), ("processes", WORKERS)] + ([("ray", WORKERS)] if ray_ok else [])
    for backend, workers in backends:
        opts = BatchOptions(backend=backend, workers=WORKERS, progress=False)  # type: ignore[arg-type]
        load = _load()
        with Executor(opts) as ex:
            # A small dataset first: starts the workers and loads the robot in each.
            startup, _ = _wall(lambda ex=ex: ik_dataset("panda", poses[:16], executor=ex))
            t, data = _wall(lambda ex=ex: ik_dataset("panda", poses, executor=ex))
        rows.append(
            Row(
                SUITE,
                f"ik_dataset panda {n} poses",
                f"taskspace {backend}",
                Timing.from_samples([t / n]),
                {
                    "poses_per_s": n / t,
                    "poses_per_s_per_core": n / t / workers,
                    "success_rate": data.success_rate,
                    "chunk_size": data.batch.chunk_size,
                    "startup_s": startup,
                    "load1": load,
                },
                ratio_to="taskspace serial",
            )
        )
    return rows


def run(quick: bool) -> list[Row]:
    ray_start = _ray_ready()
    ray_ok = ray_start is not None
    rows = (
        [
            Row(
                SUITE,
                "ray runtime",
                "ray.init(num_cpus=2)",
                Timing.from_samples([ray_start or 0.0]),
                {"load1": _load()},
                note="start-up of the local runtime, excluded from the per-task rows",
            )
        ]
        if ray_ok
        else []
    )
    rows += _overhead(quick, ray_ok)
    rows += _per_task(quick, ray_ok)
    rows += _campaign(quick, ray_ok)
    rows += _ik_dataset(quick, ray_ok)
    return rows
