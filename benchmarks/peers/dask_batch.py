"""Dask peer for the batch suite (runs in .venv-peers/dask).

Prints one JSON line with the wall time [s] of
* ``overhead``: ``n`` CPU-bound tasks of ``seconds`` each, one future per task, on a
  ``LocalCluster`` of 2 worker processes with one thread each (cluster start-up included, as the
  pool start-up is for ``multiprocessing.Pool`` and taskspace's executor in the same suite);
* ``per_task``: ``m`` no-op tasks on the warm cluster (what the scheduler costs per task);
* ``startup``: the cluster start-up alone.
Usage: ``python dask_batch.py N SECONDS M``.
"""

from __future__ import annotations

import json
import sys
import time


def spin(seconds: float) -> int:
    """Busy for ``seconds`` (the task of the batch suite's overhead row)."""
    end = time.perf_counter() + seconds
    n = 0
    while time.perf_counter() < end:
        n += 1
    return n


def noop(x: int) -> int:
    return x


def main() -> None:
    from distributed import Client, LocalCluster

    n, seconds, m = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
    t0 = time.perf_counter()
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    client = Client(cluster)
    startup = time.perf_counter() - t0
    futures = client.map(spin, [seconds] * n, pure=False)
    client.gather(futures)
    overhead = time.perf_counter() - t0
    client.gather(client.map(noop, range(20), pure=False))  # warm
    t1 = time.perf_counter()
    client.gather(client.map(noop, range(m), pure=False))
    per_task = time.perf_counter() - t1
    client.close()
    cluster.close()
    print(json.dumps({"overhead": overhead, "per_task": per_task, "startup": startup}))


if __name__ == "__main__":
    main()
