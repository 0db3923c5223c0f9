"""Batch work: one executor over serial, local-process and Ray backends.

``Executor(BatchOptions(backend=...)).map(fn, items)`` runs a pure task function
``fn(item, rng, context)`` over many inputs with deterministic per-task seeds, a per-worker
context, chunking, retries of tasks whose worker died, a progress bar and a resumable JSON
Lines results file; ``write_sqlite`` turns a campaign into an OMPL-style database (one row
per run).

The names are imported on first use: a worker process, which unpickles
``taskspace.batch.worker.run_chunk``, thus imports the worker's few modules and not the
executor's (tqdm, sqlite, the backends), about 45 ms less per worker start.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from taskspace.batch.database import read_sqlite, write_sqlite
    from taskspace.batch.executor import BatchOptions, Executor, run_batch
    from taskspace.batch.records import (
        BatchError,
        BatchResult,
        BatchStatus,
        TaskRecord,
        iter_records,
    )
    from taskspace.batch.worker import task_rng

_HOMES = {
    "read_sqlite": "database",
    "write_sqlite": "database",
    "BatchOptions": "executor",
    "Executor": "executor",
    "run_batch": "executor",
    "BatchError": "records",
    "BatchResult": "records",
    "BatchStatus": "records",
    "TaskRecord": "records",
    "iter_records": "records",
    "task_rng": "worker",
}

__all__ = [
    "BatchError",
    "BatchOptions",
    "BatchResult",
    "BatchStatus",
    "Executor",
    "TaskRecord",
    "iter_records",
    "read_sqlite",
    "run_batch",
    "task_rng",
    "write_sqlite",
]


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'taskspace.batch' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"taskspace.batch.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
