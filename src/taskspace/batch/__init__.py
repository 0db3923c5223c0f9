"""Batch work: one executor over serial, local-process and Ray backends.

``Executor(BatchOptions(backend=...)).map(fn, items)`` runs a pure task function
``fn(item, rng, context)`` over many inputs with deterministic per-task seeds, a per-worker
context, chunking, retries of tasks whose worker died, a progress bar and a resumable JSON
Lines results file; ``write_sqlite`` turns a campaign into an OMPL-style database (one row
per run).
"""

from taskspace.batch.database import read_sqlite, write_sqlite
from taskspace.batch.executor import BatchOptions, Executor, run_batch
from taskspace.batch.records import BatchError, BatchResult, BatchStatus, TaskRecord, iter_records
from taskspace.batch.worker import task_rng

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
