"""One executor for batch work: serial, local processes (the default) or Ray.

A batch is a pure task function ``fn(item, rng, context) -> value`` applied to a sequence of
inputs. ``rng`` is the task's own generator, derived from the run's seed and the task's index
(``SeedSequence(seed, spawn_key=(index,))``), so the values are the same whatever the backend,
the number of workers and the chunking. ``context`` is built once per worker by a picklable
factory (a robot model, a scene) instead of being shipped with every task.

Thread safety: :class:`BatchOptions` is immutable; an :class:`Executor` runs one batch at a time
(a second concurrent run raises :class:`~taskspace.errors.ConcurrentUseError`).
"""

from __future__ import annotations

import hashlib
import math
import os
import pickle
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from tqdm import tqdm

from taskspace.batch.chunk import ChunkQueue
from taskspace.batch.processes import ProcessPool, run_processes
from taskspace.batch.ray_backend import RayPool, run_ray
from taskspace.batch.records import BatchError, BatchResult, ResultsFile, TaskRecord, roundtrip
from taskspace.batch.serial import run_serial
from taskspace.batch.worker import TaskFunction
from taskspace.errors import ConcurrentUseError, InvalidInputError, UnknownNameError

Backend = Literal["serial", "processes", "ray"]
BACKENDS = ("serial", "processes", "ray")
START_METHODS = ("forkserver", "spawn", "fork")


MAX_WORKERS = 4096
"""Most workers of an executor (processes, or Ray actors on a cluster)."""
MAX_RETRIES = 100
"""Most restarts of a chunk whose worker died (a task that always kills its worker fails)."""
RAY_MIN_CHUNK_SECONDS = 0.1
"""The shortest automatic chunk on Ray [s]: a chunk costs the driver, Ray and the actor about
1 ms of CPU there (0.2 ms with local processes), so 0.1 s keeps that near 1 %."""


@dataclass(frozen=True, kw_only=True)
class BatchOptions:
    """Settings of an :class:`Executor`.

    Attributes:
        backend: ``"serial"`` (this process), ``"processes"`` (local worker processes) or
            ``"ray"`` (a Ray runtime: local, or a cluster through ``ray_address``).
        workers: worker processes (None: every core of this machine); for Ray, the actors
            (at most, and with None all of, the cluster's free CPUs) and the CPUs of the local
            runtime it starts.
        chunk_size: tasks sent to a worker at once (None: one at first, then chosen so that
            a chunk takes at least ``min_chunk_seconds``, from the fastest task finished so
            far, and fewer toward the end of the run; see
            :class:`~taskspace.batch.chunk.ChunkQueue`).
        min_chunk_seconds: the shortest chunk worth sending [s]. Ray's documentation puts the
            least task worth distributing at about 10 ms; process pools pay about 0.1-1 ms.
            On Ray, automatic chunks last at least ``RAY_MIN_CHUNK_SECONDS``.
        retries: how many more times a chunk whose worker died is run before its tasks are
            split and, alone, reported as failed. An exception raised by the task function is
            not retried (it would raise again): its task is reported with the traceback.
        seed: the run's seed; task ``i`` draws from ``SeedSequence(seed, spawn_key=(i,))``.
        progress: show a progress bar (tqdm, on stderr).
        ray_address: None to start a local Ray runtime, ``"auto"`` for the cluster started on
            this machine by ``ray start --head``, or ``"ray://HOST:10001"``.
        start_method: how worker processes start (``"forkserver"``, ``"spawn"``, ``"fork"``).
    """

    backend: Backend = "processes"
    workers: int | None = None
    chunk_size: int | None = None
    min_chunk_seconds: float = 0.01
    retries: int = 2
    seed: int = 0
    progress: bool = True
    ray_address: str | None = None
    start_method: str = "forkserver"

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise UnknownNameError("backend", str(self.backend), BACKENDS)
        for name in ("workers", "chunk_size"):
            value = getattr(self, name)
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int) or value < 1
            ):
                raise InvalidInputError(f"{name} must be a positive integer or None, got {value!r}")
        if self.workers is not None and self.workers > MAX_WORKERS:
            raise InvalidInputError(f"workers must be at most {MAX_WORKERS}, got {self.workers}")
        if (
            isinstance(self.retries, bool)
            or not isinstance(self.retries, int)
            or not 0 <= self.retries <= MAX_RETRIES
        ):
            raise InvalidInputError(
                f"retries must be an integer in [0, {MAX_RETRIES}], got {self.retries!r}"
            )
        if not isinstance(self.progress, bool):
            raise InvalidInputError(f"progress must be True or False, got {self.progress!r}")
        if isinstance(self.seed, np.integer):  # numpy's integers are integers
            object.__setattr__(self, "seed", int(self.seed))
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InvalidInputError(f"seed must be an integer >= 0, got {self.seed!r}")
        if (
            isinstance(self.min_chunk_seconds, bool)
            or not isinstance(self.min_chunk_seconds, (int, float))
            or not self.min_chunk_seconds >= 0
        ):
            raise InvalidInputError(
                f"min_chunk_seconds must be a number >= 0, got {self.min_chunk_seconds!r}"
            )
        if not math.isfinite(self.min_chunk_seconds):
            raise InvalidInputError("min_chunk_seconds must be finite")
        if self.ray_address is not None and not isinstance(self.ray_address, str):
            raise InvalidInputError(
                "ray_address must be None (a local Ray runtime), 'auto' or 'ray://HOST:PORT', "
                f"got {self.ray_address!r}"
            )
        if self.start_method not in START_METHODS:
            raise UnknownNameError(
                "start_method", self.start_method, ("forkserver", "spawn", "fork")
            )


class Executor:
    """Runs batches of tasks on one backend.

    Example:
        >>> ex = Executor(BatchOptions(backend="processes", workers=2))
        >>> ex.map(square, range(100)).values  # doctest: +SKIP

    Task functions, their inputs and the context factory must be picklable (module-level
    functions, ``functools.partial`` of them) for every backend but ``"serial"``.

    Thread safety: one run at a time per executor. Its workers (processes, Ray actors) are
    kept between runs and serve one run; a second :meth:`map` or :meth:`as_completed` started
    while a run is in progress (from another thread, or a second stream interleaved in the
    same thread) raises :class:`~taskspace.errors.ConcurrentUseError`: use one executor per
    concurrent run. Options, records and results are plain data.
    """

    def __init__(self, options: BatchOptions | None = None) -> None:
        self.options = options or BatchOptions()
        self.workers = self.options.workers or os.cpu_count() or 1
        self._pool = ProcessPool(self.workers, self.options.start_method)
        self._actors = RayPool(self.options.workers, self.options.ray_address)
        self.last_chunk_size = 0
        self._running = threading.Lock()

    def close(self) -> None:
        """Stop the workers kept between runs (processes, or the Ray backend's actors)."""
        self._pool.discard()
        self._actors.discard()

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        for name in ("_pool", "_actors"):
            pool = getattr(self, name, None)
            if pool is not None:
                pool.discard()

    def as_completed(
        self,
        fn: TaskFunction,
        items: Sequence[Any],
        *,
        context: Callable[[], Any] | None = None,
        results_file: str | os.PathLike[str] | None = None,
        description: str = "tasks",
    ) -> Iterator[TaskRecord]:
        """Yield each task's record as soon as it finishes (completion order).

        Args:
            fn: the task function ``fn(item, rng, context) -> value``.
            items: the inputs, one task each.
            context: a picklable factory of the per-worker context (called once per worker).
            results_file: a JSON Lines file written as tasks finish; tasks already recorded
                there by an interrupted run of the same inputs and seed are not run again.
                With a file, values are returned as they read back from it (arrays as lists).
            description: the progress bar's label.

        Yields:
            One :class:`TaskRecord` per input (resumed ones first).

        Raises:
            BatchError: if the results file belongs to another run.
        """
        if not callable(fn):
            raise InvalidInputError(f"fn must be callable, got {type(fn).__name__}")
        if context is not None and not callable(context):
            raise InvalidInputError(
                f"context must be a factory (a callable returning the context), got {context!r}"
            )
        try:
            items = list(items)
        except TypeError as exc:
            raise InvalidInputError(
                f"items must be an iterable of task inputs (a list, a range...), got "
                f"{type(items).__name__}"
            ) from exc
        if not self._running.acquire(blocking=False):
            raise ConcurrentUseError("Executor.map/as_completed (one run at a time per executor)")
        try:
            yield from self._run(fn, items, context, results_file, description)
        finally:
            self._running.release()

    def _run(
        self,
        fn: TaskFunction,
        items: list[Any],
        context: Callable[[], Any] | None,
        results_file: str | os.PathLike[str] | None,
        description: str,
    ) -> Iterator[TaskRecord]:
        n = len(items)
        opts = self.options
        if opts.backend == "processes":  # Ray pickles with cloudpickle (lambdas included)
            _require_picklable(fn, "fn")
            _require_picklable(context, "context")
        store = None
        done: dict[int, TaskRecord] = {}
        if results_file is not None:
            store = ResultsFile(results_file, {"tasks": n, "seed": opts.seed})
            try:
                done = store.load()
            except OSError as exc:
                raise InvalidInputError(
                    f"results_file {str(results_file)!r} cannot be read: {exc}"
                ) from exc
        todo = [(i, x) for i, x in enumerate(items) if i not in done]
        bar = tqdm(total=n, initial=len(done), desc=description, disable=not opts.progress)
        if store is not None:
            try:
                store.open()
            except OSError as exc:
                bar.close()
                raise InvalidInputError(
                    f"results_file {str(results_file)!r} cannot be written: {exc}"
                ) from exc
        try:
            yield from done.values()
            if not todo:
                return
            key = _context_key(context)
            # The workers start and build the context before their first chunk arrives.
            if opts.backend == "ray":
                self._actors.start(fn, key, context, opts.seed)
            elif opts.backend == "processes" and opts.chunk_size is None:
                self._pool.warm(key, context)
            # Automatic chunks: the first ones hold one task each, later ones are sized from
            # the times of the tasks finished so far (in the workers: the driver builds no
            # context and runs no task of its own) and shrink toward the end of the run.
            least = opts.min_chunk_seconds
            if opts.backend == "ray":
                least = max(least, RAY_MIN_CHUNK_SECONDS)
            size = opts.chunk_size or (1 if opts.backend == "serial" else None)
            chunks = ChunkQueue(todo, size, self.workers, least)
            self.last_chunk_size = 0
            try:
                for records in self._backend(fn, key, context, chunks):
                    chunks.observe(records)
                    yield from self._finish(records, store, bar)
            finally:
                self.last_chunk_size = chunks.largest
        finally:
            bar.close()
            if store is not None:
                store.close()

    def _backend(
        self, fn: TaskFunction, key: str, context: Callable[[], Any] | None, chunks: ChunkQueue
    ) -> Iterator[list[TaskRecord]]:
        opts = self.options
        args = (fn, key, context, chunks, opts.seed, self.workers, opts.retries)
        if opts.backend == "serial":
            return run_serial(*args)
        if opts.backend == "processes":
            return run_processes(*args, pools=self._pool)
        return run_ray(*args, pool=self._actors)

    @staticmethod
    def _finish(
        records: list[TaskRecord], store: ResultsFile | None, bar: Any
    ) -> Iterator[TaskRecord]:
        if store is not None:
            store.append(records)
            records = [replace(r, value=roundtrip(r.value)) if r.ok else r for r in records]
        bar.update(len(records))
        yield from records

    def map(
        self,
        fn: TaskFunction,
        items: Sequence[Any],
        *,
        context: Callable[[], Any] | None = None,
        results_file: str | os.PathLike[str] | None = None,
        description: str = "tasks",
    ) -> BatchResult:
        """Run every task and return the records in input order.

        Arguments as :meth:`as_completed`. A failing task does not stop the run: its record
        carries the error and the input (``result.failures``); ``result.values`` raises a
        :class:`BatchError` listing them.
        """
        t0 = time.perf_counter()
        records = sorted(
            self.as_completed(
                fn, items, context=context, results_file=results_file, description=description
            ),
            key=lambda r: r.index,
        )
        return BatchResult(
            records=records,
            backend=self.options.backend,
            workers=1 if self.options.backend == "serial" else self.workers,
            chunk_size=self.last_chunk_size,
            seconds=time.perf_counter() - t0,
            n_resumed=sum(r.resumed for r in records),
        )


def _require_picklable(obj: Any, name: str) -> None:
    try:
        pickle.dumps(obj)
    except Exception as exc:
        raise InvalidInputError(
            f"{name} must be picklable for the processes backend (a module-level function or a "
            f"functools.partial of one, not a lambda or a local function): {exc}"
        ) from exc


def _context_key(factory: Callable[[], Any] | None) -> str:
    """A name for a context factory, equal for equal factories (e.g. the same ``partial``).

    A worker thus reuses the context it built in an earlier run of the same executor.
    """
    try:
        return hashlib.sha1(pickle.dumps(factory)).hexdigest()
    except Exception:  # not picklable: only the serial backend can run it anyway
        return uuid.uuid4().hex


def run_batch(
    fn: TaskFunction,
    items: Sequence[Any],
    *,
    context: Callable[[], Any] | None = None,
    results_file: str | os.PathLike[str] | Path | None = None,
    options: BatchOptions | None = None,
) -> BatchResult:
    """Run ``fn`` over ``items`` with an :class:`Executor` of ``options`` (see its ``map``)."""
    with Executor(options) as executor:
        return executor.map(fn, items, context=context, results_file=results_file)


__all__ = ["BatchError", "BatchOptions", "Executor", "run_batch"]
