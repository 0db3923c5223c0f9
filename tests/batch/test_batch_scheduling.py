"""How a run is cut and started: chunks sized from the task times, warm-up, lazy imports."""

from __future__ import annotations

import functools
import math
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
from taskspace.batch.chunk import ChunkQueue, make_chunks
from taskspace.batch.records import TaskRecord

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


def _gss_sizes(n: int, size: int, workers: int) -> list[int]:
    """Guided self-scheduling enumerated: ceil(remaining / 2P) per chunk, capped at size."""
    sizes, remaining = [], n
    while remaining:
        sizes.append(max(1, min(size, -(-remaining // (2 * workers)))))
        remaining -= sizes[-1]
    return sizes


@pytest.mark.parametrize(
    ("n", "workers", "least", "seconds", "size"),
    [(200, 2, 0.01, 0.001, 10), (1050, 2, 0.1, 0.03, 4), (1050, 2, 0.01, 0.05, 1),
     (9, 4, 0.01, 1e-4, 1), (100, 2, 1.0, 1e-3, 13)],
)  # fmt: skip
def test_automatic_chunks_are_sized_from_the_tasks_that_came_back(
    n: int, workers: int, least: float, seconds: float, size: int
) -> None:
    tasks = [(i, f"x{i}") for i in range(n)]
    queue = ChunkQueue(tasks, None, workers, least)
    first = [queue.popleft() for _ in range(min(n, 2 * workers))]
    assert [len(c.tasks) for c in first] == [1] * len(first)  # no time known yet
    # a failure that never ran (a dead worker: 0 s), a resumed record and a fast failure
    # say nothing about the task time
    queue.observe([TaskRecord(0, False, error="worker died"), TaskRecord(1, True, 0, resumed=True)])
    queue.observe([TaskRecord(2, False, error="ValueError", seconds=1e-9)])
    assert queue.size == 1
    queue.observe([TaskRecord(i, True, 0, seconds=seconds * (1 + i)) for i in range(3)])
    # size: ceil(least / fastest), at most ceil(n / 4P) (the hand-computed column)
    assert queue.size == size == max(1, min(math.ceil(least / seconds), -(-n // (4 * workers))))
    rest = []
    while queue:
        rest.append(queue.popleft())
    assert [len(c.tasks) for c in rest] == _gss_sizes(n - len(first), size, workers)
    assert [t for c in first + rest for t in c.tasks] == tasks  # each task once, in order
    assert queue.largest == max(len(c.tasks) for c in first + rest)
    with pytest.raises(IndexError):
        queue.popleft()


def test_a_fixed_chunk_size_is_kept_to_the_end() -> None:
    tasks = [(i, i) for i in range(23)]
    queue = ChunkQueue(tasks, 5, 2, 0.01)
    queue.observe([TaskRecord(0, True, 0, seconds=1e-6)])  # ignored: the size is the user's
    sizes = []
    while queue:
        sizes.append(len(queue.popleft().tasks))
    assert sizes == [5, 5, 5, 5, 3] == [len(c.tasks) for c in make_chunks(tasks, 5)]


def test_the_driver_runs_no_task_and_builds_no_context() -> None:
    # before: the driver built the context and timed up to 3 tasks itself to size the
    # chunks (a third copy of a scene on 2 workers, competing with their start-up)
    built_here = T._SERIAL[0]
    opts = BatchOptions(backend="processes", workers=2, progress=False, seed=6)
    with Executor(opts) as ex:
        result = ex.map(T.context_pid, range(40), context=T.make_context)
        noisy = ex.map(T.noisy, list(range(40)))
    assert T._SERIAL[0] == built_here
    assert all(pid != os.getpid() for pid, _, _ in result.values)
    assert noisy.values == _reference(list(range(40)), 6)
    assert 1 <= result.chunk_size <= 5


def test_automatic_chunks_on_processes_give_the_reference_values() -> None:
    items = list(range(61))
    opts = BatchOptions(backend="processes", workers=2, progress=False, seed=11)
    with Executor(opts) as ex:
        result = ex.map(T.noisy, items, context=T.make_context)
        rows = ex.map(T.context_pid, range(30), context=T.make_context).values
    assert result.values == _reference(items, 11)
    # every task ran in a worker, which built the context once for both runs
    assert all(pid != os.getpid() for pid, _, _ in rows)
    assert all(pid == ctx_pid and serial == 1 for pid, ctx_pid, serial in rows)


def test_processes_warm_up_starts_every_worker_at_once() -> None:
    # the context takes 0.3 s: warmed workers have it built when their first chunk arrives
    opts = BatchOptions(backend="processes", workers=2, progress=False)
    with Executor(opts) as ex:
        ex._pool.warm("key-of-nothing", T.slow_context)
        time.sleep(0.1)
        pids = {p.pid for p in ex._pool.get()._processes.values()}  # type: ignore[union-attr]
        assert len(pids) == 2  # both started at once, before any chunk
    deadline = time.monotonic() + 60  # bounds a hang only
    while time.monotonic() < deadline and any(_alive(p) for p in pids):
        time.sleep(0.05)
    assert not any(_alive(p) for p in pids), "warmed workers outlived close()"


def test_the_executor_warms_every_worker() -> None:
    # 3 tasks: both workers are started and build the context, whichever gets the tasks
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
        deadline = time.monotonic() + 60  # bounds a hang only
        while _alive(victim) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(victim), "the killed worker was not reaped in 60 s"
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
