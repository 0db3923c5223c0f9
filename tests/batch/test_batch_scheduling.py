"""How a run is cut and started: tapered chunks, workers warmed during the probe, lazy imports."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import _batch_tasks as T
import numpy as np
import pytest

from taskspace.batch import BatchOptions, Executor
from taskspace.batch.chunk import make_chunks

HERE = Path(__file__).resolve().parent


def _reference(items: list[int], seed: int) -> list[list[float]]:
    """T.noisy computed here with the documented per-task SeedSequence (not our task_rng)."""
    out = []
    for i in items:
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i,)))
        out.append((float(i) + rng.standard_normal(3)).tolist())
    return out


@pytest.mark.parametrize(
    ("n", "size", "workers"), [(100, 10, 2), (1050, 2, 2), (7, 3, 4), (1, 5, 2)]
)
def test_tapered_chunks_keep_every_task_in_order_and_end_small(
    n: int, size: int, workers: int
) -> None:
    tasks = [(i, f"x{i}") for i in range(n)]
    chunks = make_chunks(tasks, size, workers)
    sizes = [len(c.tasks) for c in chunks]
    assert [t for c in chunks for t in c.tasks] == tasks
    assert max(sizes) <= size and min(sizes) >= 1
    assert sizes == sorted(sizes, reverse=True)  # never larger again
    # guided self-scheduling: at most ceil(remaining / (2 workers)) tasks per chunk
    remaining = n
    for s in sizes:
        assert s <= max(1, -(-remaining // (2 * workers)))
        remaining -= s
    # the last 2 * workers tasks go one by one (the workers finish together)
    assert all(s == 1 for s in sizes[-min(n, 2 * workers) :])
    # and nothing is cut finer than needed: full chunks while there is enough left
    full = max(0, n - 2 * workers * size) // size
    assert sizes[:full] == [size] * full
    assert [len(c.tasks) for c in make_chunks(tasks, size)] == [
        min(size, n - i) for i in range(0, n, size)
    ]


def test_automatic_chunks_on_processes_give_the_reference_values() -> None:
    items = list(range(61))
    opts = BatchOptions(backend="processes", workers=2, progress=False, seed=11)
    with Executor(opts) as ex:
        result = ex.map(T.noisy, items, context=T.make_context)
        rows = ex.map(T.context_pid, range(30), context=T.make_context).values
    assert result.values == _reference(items, 11)
    # the driver ran the probe tasks; the workers were warmed meanwhile and built the
    # context once each for both runs
    in_workers = [row for row in rows if row[0] != os.getpid()]
    assert in_workers
    assert all(pid == ctx_pid and serial == 1 for pid, ctx_pid, serial in in_workers)


def test_processes_warm_up_starts_the_workers_during_the_probe() -> None:
    # the context takes 0.3 s: warmed workers have it built when their first chunk arrives,
    # so their first task starts soon after the probe (cold: 0.3 s + start-up later)
    opts = BatchOptions(backend="processes", workers=2, progress=False)
    with Executor(opts) as ex:
        ex._pool.warm("key-of-nothing", T.slow_context)
        time.sleep(0.1)
        pids = {p.pid for p in ex._pool.get()._processes.values()}  # type: ignore[union-attr]
        assert len(pids) == 2  # both started at once, before any chunk
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(p) for p in pids):
        time.sleep(0.05)
    assert not any(_alive(p) for p in pids), "warmed workers outlived close()"


def test_the_executor_warms_every_worker_while_it_probes() -> None:
    # 3 tasks: the driver probes 2 and one chunk is left, which starts one worker; the
    # warm-up during the probe started both and built the context in each
    opts = BatchOptions(backend="processes", workers=2, progress=False)
    with Executor(opts) as ex:
        result = ex.map(T.context_pid, range(3), context=T.make_context)
        processes = ex._pool.get()._processes  # type: ignore[union-attr]
        assert len(processes) == 2
        rows = ex.map(T.context_pid, range(40), context=T.make_context).values
    assert result.success
    assert all(serial == 1 for pid, _, serial in rows if pid != os.getpid())


def test_a_worker_killed_between_runs_is_replaced() -> None:
    # before: the pool broken by a worker killed while idle refused the next run's chunks
    # (BrokenProcessPool out of map)
    opts = BatchOptions(backend="processes", workers=2, chunk_size=1, progress=False, seed=4)
    with Executor(opts) as ex:
        assert ex.map(T.noisy, range(10)).success
        victim = next(iter(ex._pool.get()._processes))  # type: ignore[union-attr]
        os.kill(victim, signal.SIGKILL)
        deadline = time.monotonic() + 10
        while _alive(victim) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)  # the pool notices the death
        result = ex.map(T.noisy, list(range(10)))
    assert result.values == _reference(list(range(10)), 4)


def test_a_worker_dying_while_warming_up_loses_nothing(tmp_path: Path) -> None:
    factory = functools.partial(T.dies_first_in_a_worker, os.getpid(), str(tmp_path))
    items = list(range(40))
    opts = BatchOptions(backend="processes", workers=2, progress=False, seed=3)
    with Executor(opts) as ex:
        result = ex.map(T.noisy, items, context=factory)
        again = ex.map(T.noisy, items, context=factory)
    assert (tmp_path / "context-died").exists()
    assert result.values == _reference(items, 3) == again.values


def test_a_worker_imports_the_worker_modules_only() -> None:
    code = (
        "import sys, taskspace.batch.worker\n"
        "heavy = [m for m in ('tqdm', 'sqlite3', 'taskspace.batch.executor',"
        " 'taskspace.batch.ray_backend', 'concurrent.futures.process') if m in sys.modules]\n"
        "print(heavy)\n"
        "from taskspace.batch import *\n"
        "import taskspace.batch as b\n"
        "print(sorted(n for n in b.__all__ if n not in globals()))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split("\n")
    assert out[0] == "[]" and out[1] == "[]"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True
