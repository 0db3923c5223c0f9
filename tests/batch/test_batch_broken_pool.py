"""A worker that dies between two submissions: the run goes on in a new pool.

Before: ``run_processes`` submitted the next chunks outside the handling of a dead worker, so
a worker killed while the caller held the generator (between two yielded chunks) made the
next ``submit`` raise ``BrokenProcessPool`` out of the run. A real pool, a real SIGKILL.
"""

from __future__ import annotations

import os
import signal
import time

import _batch_tasks as T
import numpy as np
import pytest

from taskspace.batch.chunk import ChunkQueue
from taskspace.batch.processes import ProcessPool, run_processes


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_a_worker_killed_between_chunks_does_not_end_the_run() -> None:
    tasks = list(enumerate(range(12)))
    pools = ProcessPool(2, "forkserver")
    try:
        queue = ChunkQueue(tasks, 1, 2, 0.01)
        stream = run_processes(T.noisy, "key", None, queue, 7, 2, 2, pools)
        records = list(next(stream))  # the caller holds the generator here
        pool = pools.get()
        victim = next(iter(pool._processes.values()))  # type: ignore[union-attr]
        os.kill(victim.pid, signal.SIGKILL)
        deadline = time.monotonic() + 60.0  # the pool notices the death (a hang bound)
        while not getattr(pool, "_broken", False) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert getattr(pool, "_broken", False)
        for chunk in stream:
            records += chunk
    finally:
        pools.discard()
    by_index = {r.index: r for r in records}
    assert sorted(by_index) == list(range(12))
    assert all(r.ok for r in by_index.values())
    # the values are the task's own (per-task seeds), whichever pool ran them
    for i, r in by_index.items():
        rng = np.random.default_rng(np.random.SeedSequence(7, spawn_key=(i,)))
        assert r.value == (float(i) + rng.standard_normal(3)).tolist()
