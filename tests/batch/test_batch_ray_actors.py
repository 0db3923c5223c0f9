"""The Ray backend's actor pool: kept between runs, killed on close and on interruption."""

from __future__ import annotations

import os
import time

import _batch_tasks as T
import numpy as np
import pytest
from _local_ray import start_local_ray

from taskspace.batch import BatchOptions, Executor

ray = pytest.importorskip("ray")
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _all_gone(pids: set[int], seconds: float = 30.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if not any(_alive(p) for p in pids):
            return True
        time.sleep(0.1)
    return False


def _ray(**kw: object) -> BatchOptions:
    return BatchOptions(backend="ray", progress=False, workers=2, **kw)  # type: ignore[arg-type]


def test_ray_actors_serve_every_run_then_stop_on_close(local_ray: None) -> None:
    items = list(range(20))
    rngs = [np.random.default_rng(np.random.SeedSequence(5, spawn_key=(i,))) for i in items]
    reference = [(i + rng.standard_normal(3)).tolist() for i, rng in zip(items, rngs)]
    with Executor(_ray(chunk_size=2, seed=5)) as ex:
        first = ex.map(T.context_pid, items, context=T.make_context).values
        values = ex.map(T.noisy, items).values  # another task function on the same actors
        second = ex.map(T.context_pid, items, context=T.make_context).values
    assert values == reference
    pids = {r[0] for r in first}
    assert len(pids) <= 2 and pids != {os.getpid()}
    assert {r[0] for r in second} <= pids  # the same actors
    assert all(pid == ctx_pid for pid, ctx_pid, _ in first + second)
    # each actor built the context once per run of it (the noisy run had no context)
    assert all(serial == 1 for *_, serial in first)
    assert _all_gone(pids), "actors outlived Executor.close()"


def test_interrupted_ray_run_stops_its_actors(local_ray: None) -> None:
    ex = Executor(_ray(chunk_size=1))
    stream = ex.as_completed(T.slow_pid, range(200))
    pids = {next(stream).value for _ in range(4)}
    stream.close()  # as an interrupted campaign does (Ctrl-C reaches the generator)
    assert pids and os.getpid() not in pids
    assert _all_gone(pids), "actors outlived the interrupted run"
    # the executor still works: new actors, the serial values
    again = ex.map(T.noisy, range(6)).values
    ex.close()
    serial = Executor(BatchOptions(backend="serial", progress=False)).map(T.noisy, range(6))
    assert again == serial.values


def test_ray_executor_outlives_a_ray_restart(local_ray: None) -> None:
    serial = Executor(BatchOptions(backend="serial", progress=False)).map(T.noisy, range(6))
    with Executor(_ray(chunk_size=2)) as ex:
        assert ex.map(T.noisy, range(6)).values == serial.values
        ray.shutdown()  # the executor's actors went with it
        start_local_ray()
        assert ex.map(T.noisy, range(6)).values == serial.values  # new actors
