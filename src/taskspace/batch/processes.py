"""The local-processes backend: a ``ProcessPoolExecutor`` that survives dying workers.

A worker that dies (killed, or a crash inside a compiled kernel) breaks the whole pool and
every chunk in flight with it, and the pool cannot tell which chunk was at fault. The chunks
in flight are then run again one at a time in a new pool, where a death is attributable: a
chunk whose worker dies ``retries + 1`` times alone is split into single tasks, and a single
task that does so is reported as failed with its input. Every other task completes.
"""

from __future__ import annotations

import multiprocessing
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from taskspace.batch.chunk import Chunk, ChunkQueue
from taskspace.batch.records import TaskRecord
from taskspace.batch.worker import TaskFunction, ignore_sigint, run_chunk, worker_context


def _new_pool(workers: int, start_method: str) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context(start_method),
        initializer=ignore_sigint,
    )


def _stop(pool: ProcessPoolExecutor | None) -> None:
    """Stop a pool now: cancel what is queued and end the workers (no waiting on them)."""
    if pool is None:
        return
    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    for p in processes:
        p.join(timeout=5)


def _warm(key: str, factory: Callable[[], Any]) -> None:
    try:
        worker_context(key, factory)
    except Exception:  # run_chunk reports it on each task of the run
        pass


def _unsendable(exc: BaseException) -> str:
    return (
        f"the chunk's results could not be sent back from the worker ({exc!r}): task values "
        "must be picklable (numbers, arrays, dicts, dataclasses; not lambdas or open files)"
    )


class ProcessPool:
    """A pool kept between runs, replaced when a worker death breaks it.

    Worker start-up and imports are thus paid once per executor, not once per run.
    """

    def __init__(self, workers: int, start_method: str) -> None:
        self.workers = workers
        self.start_method = start_method
        self._pool: ProcessPoolExecutor | None = None

    def get(self) -> ProcessPoolExecutor:
        """The live pool (started on first use, replaced if a worker died since the last run)."""
        if self._pool is not None and getattr(self._pool, "_broken", False):
            self.discard()
        if self._pool is None:
            self._pool = _new_pool(self.workers, self.start_method)
        return self._pool

    def warm(self, key: str, factory: Callable[[], Any] | None) -> None:
        """Start the workers and have them build the run's context, without waiting.

        Called before the driver times its probe tasks, so that worker start-up, imports and
        the context (a robot, a scene) overlap the probe instead of following it. A worker
        that fails or dies here changes nothing: the run's chunks build the context again
        (and report its error), and a pool broken meanwhile is replaced by :meth:`get`.
        """
        if factory is None:
            return
        pool = self.get()
        for _ in range(self.workers):  # one call per worker (a pool starts one per call)
            pool.submit(_warm, key, factory)

    def discard(self) -> None:
        """Stop the pool and its workers; the next :meth:`get` starts a new one."""
        _stop(self._pool)
        self._pool = None


def run_processes(
    fn: TaskFunction,
    key: str,
    factory: Callable[[], Any] | None,
    chunks: ChunkQueue,
    seed: int,
    workers: int,
    retries: int,
    pools: ProcessPool,
) -> Iterator[list[TaskRecord]]:
    """Yield each chunk's records as it finishes, in completion order.

    An interruption (Ctrl-C, or the caller closing the generator) stops the pool's workers.
    """
    queue = chunks  # cut as the workers take them
    suspects: deque[Chunk] = deque()
    finished = False
    try:
        while queue or suspects:
            pool = pools.get()
            if suspects:  # alone in the pool: a death is this chunk's
                chunk = suspects.popleft()
                chunk.attempts += 1
                try:
                    records = pool.submit(run_chunk, fn, key, factory, chunk.tasks, seed).result()
                except BrokenProcessPool as exc:
                    pools.discard()
                    reason = f"{exc} (alone, {chunk.crashes + 1} times)"
                    if died := chunk.crashed_alone(retries, suspects, reason):
                        yield died
                    continue
                except Exception as exc:  # the records could not be sent back
                    yield chunk.failed(_unsendable(exc))
                    continue
                yield chunk.stamp(records)
                continue
            in_flight: dict[Future[list[TaskRecord]], Chunk] = {}
            broken = False
            while (queue or in_flight) and not broken:
                while queue and len(in_flight) < 2 * workers:
                    chunk = queue.popleft()
                    chunk.attempts += 1
                    try:
                        future = pool.submit(run_chunk, fn, key, factory, chunk.tasks, seed)
                    except BrokenProcessPool:
                        # a worker died since the last submission (e.g. while the caller
                        # held this generator): this chunk never ran; it runs alone in the
                        # next pool, the chunks in flight are sorted out below
                        chunk.attempts -= 1
                        suspects.append(chunk)
                        broken = True
                        break
                    in_flight[future] = chunk
                if broken:
                    break
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                for future in done:
                    chunk = in_flight.pop(future)
                    try:
                        records = future.result()
                    except BrokenProcessPool:
                        suspects.append(chunk)
                        broken = True
                    except Exception as exc:  # the records could not be sent back
                        yield chunk.failed(_unsendable(exc))
                    else:
                        yield chunk.stamp(records)
            if broken:
                for future, chunk in in_flight.items():
                    if future.done() and not future.cancelled() and future.exception() is None:
                        yield chunk.stamp(future.result())
                    else:
                        suspects.append(chunk)
                pools.discard()
        finished = True
    finally:
        if not finished:
            pools.discard()
