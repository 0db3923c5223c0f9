"""What runs inside a worker process: a chunk of tasks, each with its own seeded generator."""

from __future__ import annotations

import signal
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from taskspace.batch.records import TaskRecord

TaskFunction = Callable[[Any, np.random.Generator, Any], Any]
"""``fn(item, rng, context) -> value``: a pure function of its input, generator and context."""

_CONTEXTS: dict[str, Any] = {}


def task_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of task ``index``: ``SeedSequence(seed, spawn_key=(index,))``.

    It depends only on the run's seed and the task's position, never on the backend, the
    worker or the chunking, so a run gives the same values serially and on any cluster.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def worker_context(key: str, factory: Callable[[], Any] | None) -> Any:
    """The context of run ``key`` in this process, built by ``factory()`` on first use.

    A robot model or a scene is thus loaded once per worker, not once per task.
    """
    if factory is None:
        return None
    try:
        return _CONTEXTS[key]
    except KeyError:
        _CONTEXTS.clear()  # one run's context at a time: a worker does not accumulate models
        _CONTEXTS[key] = factory()
        return _CONTEXTS[key]


def ignore_sigint() -> None:
    """Leave Ctrl-C to the driver, which stops the workers itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_chunk(
    fn: TaskFunction,
    key: str,
    factory: Callable[[], Any] | None,
    tasks: Sequence[tuple[int, Any]],
    seed: int,
) -> list[TaskRecord]:
    """Run ``fn`` on each ``(index, item)`` of a chunk; an exception fails its task only.

    ``SystemExit`` (a ``sys.exit`` or an argument parser inside the task) fails its task as
    any exception does, on every backend (it ended the whole run before, and the serial
    backend's program); ``KeyboardInterrupt`` still stops the run (Ctrl-C).
    """
    try:
        context = worker_context(key, factory)
    except (Exception, SystemExit) as exc:
        tb = traceback.format_exc()
        return [
            TaskRecord(i, False, error=f"context factory failed: {exc!r}", traceback=tb, item=x)
            for i, x in tasks
        ]
    out: list[TaskRecord] = []
    for index, item in tasks:
        t0 = time.perf_counter()
        try:
            value = fn(item, task_rng(seed, index), context)
        except (Exception, SystemExit) as exc:
            out.append(
                TaskRecord(
                    index,
                    False,
                    error=repr(exc),
                    traceback=traceback.format_exc(),
                    seconds=time.perf_counter() - t0,
                    item=item,
                )
            )
        else:
            out.append(TaskRecord(index, True, value, seconds=time.perf_counter() - t0))
    return out
