"""The serial backend: every chunk in this process, in order (the reference for the others)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from taskspace.batch.chunk import ChunkQueue
from taskspace.batch.records import TaskRecord
from taskspace.batch.worker import TaskFunction, run_chunk


def run_serial(
    fn: TaskFunction,
    key: str,
    factory: Callable[[], Any] | None,
    chunks: ChunkQueue,
    seed: int,
    workers: int,
    retries: int,
) -> Iterator[list[TaskRecord]]:
    """Yield each chunk's records as it finishes (``workers`` and ``retries`` are unused)."""
    del workers, retries
    while chunks:
        chunk = chunks.popleft()
        chunk.attempts += 1
        yield chunk.stamp(run_chunk(fn, key, factory, chunk.tasks, seed))
