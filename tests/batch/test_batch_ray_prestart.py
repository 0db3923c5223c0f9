"""The local Ray runtime started by taskspace: its actors run on the workers Ray started ahead."""

from __future__ import annotations

import os
import time

import _batch_tasks as T
import pytest

from taskspace.batch import BatchOptions, Executor
from taskspace.batch.ray_backend import connect

ray = pytest.importorskip("ray")
psutil = pytest.importorskip("psutil")
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]


def _idle_workers() -> set[int]:
    me = psutil.Process()
    return {p.pid for p in me.children(recursive=True) if p.name() == "ray::IDLE"}


def test_actors_start_on_the_workers_ray_started_with_the_runtime() -> None:
    # before: the driver's path went in a runtime_env, which made Ray start two new worker
    # processes for the actors (each importing Ray again) beside the two it had started
    if ray.is_initialized():
        ray.shutdown()
    before = os.environ.get("PYTHONPATH")
    try:
        connect(None, 2)
        assert os.environ.get("PYTHONPATH") == before  # only the runtime got the path
        deadline = time.monotonic() + 60
        while len(idle := _idle_workers()) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert len(idle) == 2
        opts = BatchOptions(backend="ray", workers=2, chunk_size=1, progress=False)
        with Executor(opts) as ex:
            rows = ex.map(T.context_pid, range(12), context=T.make_context).values
        # the tasks (and the context built by the task module, found through the path) ran
        # in the processes Ray had started ahead
        assert {pid for pid, _, _ in rows} == idle
        assert all(pid == ctx_pid and serial == 1 for pid, ctx_pid, serial in rows)
    finally:
        ray.shutdown()
