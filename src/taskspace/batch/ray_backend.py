"""The Ray backend: the same chunks on a pool of Ray actors, on a local runtime or a cluster.

``address=None`` starts a local runtime with ``workers`` CPUs (``ray.init(num_cpus=...)``);
``"auto"`` joins the cluster that ``ray start --head`` started on this machine (with several
clusters running Ray picks one: pass its ``"HOST:PORT"`` to be sure), and
``"ray://host:10001"`` a remote one; with no address, Ray's own ``RAY_ADDRESS`` environment
variable is honoured.

The workers are actors (one CPU each, as many as the executor's workers and at most the
cluster's free CPUs: an actor waiting for a CPU that another executor's actors hold would
hang the run, so with none free the run raises :class:`BatchError`), kept by the executor
between runs like a process pool: each one imports the
task's modules and builds the context (a robot, a scene) once, and a call to an actor goes
straight to its process instead of through Ray's task scheduler. Each actor runs one chunk at a
time, so the death of an actor is the fault of the chunk it ran: the actor is replaced, the
chunk run again up to ``retries`` times, then split into single tasks, and a single task that
keeps killing its worker is reported as failed with its input.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from taskspace.batch.chunk import Chunk, ChunkQueue
from taskspace.batch.records import BatchError, TaskRecord
from taskspace.batch.worker import TaskFunction, run_chunk, worker_context


def _ray() -> Any:
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    try:
        import ray
    except ImportError as exc:  # pragma: no cover - ray is a dependency
        raise BatchError("the 'ray' backend needs Ray: pip install 'taskspace[ray]'") from exc
    return ray


def _driver_path() -> str:
    """The driver's import path outside the interpreter's own folders, as a PYTHONPATH."""
    prefixes = {os.path.realpath(p) for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)}
    keep = []
    for entry in sys.path:
        path = os.path.realpath(entry or os.getcwd())
        if os.path.isdir(path) and not any(path.startswith(p) for p in prefixes):
            keep.append(path)
    return os.pathsep.join(dict.fromkeys(keep))


@contextlib.contextmanager
def _environ(name: str, value: str | None) -> Iterator[None]:
    """Environment variable ``name`` set to ``value`` inside the block (None: unchanged)."""
    if value is None:
        yield
        return
    before = os.environ.get(name)
    os.environ[name] = value
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = before


_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_MAX_REASON = 2000


def _reason(exc: BaseException) -> str:
    """Ray's whole error on one line, colour codes removed, its cause kept when shortened.

    A ``RayTaskError`` starts with ``ray::run_chunk() (pid=..., ip=...)``; what went wrong (a
    ``RaySystemError``'s "System error: ...", the worker's traceback) is on the lines after it.
    """
    lines = [line.strip() for line in _ANSI.sub("", str(exc)).splitlines() if line.strip()]
    text = f"{type(exc).__name__}: " + " | ".join(lines)
    if len(text) > _MAX_REASON:
        text = text[: _MAX_REASON // 4] + " ... " + text[-(3 * _MAX_REASON) // 4 :]
    return text


def _chain(exc: BaseException) -> str:
    """The messages of an exception and of its causes."""
    parts: list[str] = []
    seen: BaseException | None = exc
    while seen is not None and len(parts) < 10:
        parts.append(str(seen))
        seen = seen.__cause__ or seen.__context__
    return " <- ".join(parts)


def connect(address: str | None, workers: int) -> Any:
    """The ``ray`` module, connected (a local runtime when ``address`` is None)."""
    ray = _ray()
    address = address or os.environ.get("RAY_ADDRESS") or None
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {"log_to_driver": False, "include_dashboard": False}
        path = None
        if address is None:
            # As a forked worker would: what the driver can import, the workers can. The path
            # goes through the environment the local runtime inherits, not a runtime_env: the
            # workers Ray starts ahead at init then serve the actors (a runtime_env makes Ray
            # start new processes for them, which import Ray again: about 1 s of CPU each).
            kwargs["num_cpus"] = workers
            path = _driver_path()
        else:
            kwargs = {"address": address, "log_to_driver": False}
        try:
            with _environ("PYTHONPATH", path):
                ray.init(**kwargs)
        except Exception as exc:
            hint = (
                "for a cluster, run `ray start --head` first and pass address='auto' or "
                "'ray://HOST:10001'"
            )
            if "authentication" in _chain(exc).lower() and "RAY_AUTH_MODE" not in os.environ:
                # Ray enables token authentication for 'auto' but never for an explicit address.
                hint = (
                    "the cluster asks for Ray's token authentication, which Ray turns on for "
                    "an explicit address only with RAY_AUTH_MODE=token (the token is read from "
                    "RAY_AUTH_TOKEN or ~/.ray/auth_token)"
                )
            raise BatchError(
                f"could not start or reach Ray (address={address!r}): {_reason(exc)}; {hint}"
            ) from exc
    return ray


class RayWorker:
    """One worker of the pool: runs chunks of the run set up last (see :class:`RayPool`)."""

    def __init__(self) -> None:
        self._run: tuple[Any, str, Any, int] | None = None

    def setup(
        self, fn: TaskFunction, key: str, factory: Callable[[], Any] | None, seed: int
    ) -> int:
        """Keep the run's task function and seed; build its context now (errors: at the run)."""
        self._run = (fn, key, factory, seed)
        try:
            worker_context(key, factory)
        except Exception:  # run_chunk reports it on each task
            pass
        return os.getpid()

    def run(self, tasks: list[tuple[int, Any]]) -> list[TaskRecord]:
        """The records of one chunk of the run set up last."""
        if self._run is None:  # pragma: no cover - the pool always sets up first
            raise BatchError("RayWorker.run before setup")
        fn, key, factory, seed = self._run
        return run_chunk(fn, key, factory, tasks, seed)


_ACTOR_CLASS: list[Any] = []


def _actor_class(ray: Any) -> Any:
    if not _ACTOR_CLASS:
        # max_restarts=0: the pool replaces a dead actor itself, knowing which chunk it ran.
        _ACTOR_CLASS.append(ray.remote(num_cpus=1, max_restarts=0)(RayWorker))
    return _ACTOR_CLASS[0]


@dataclass
class RayPool:
    """Actors kept between the runs of an executor; :meth:`discard` kills them.

    Attributes:
        workers: actors wanted (None: one per CPU of the Ray cluster, which is also the most).
        address: where Ray runs (see :func:`connect`).
    """

    workers: int | None
    address: str | None = None
    actors: list[Any] = field(default_factory=list)
    _run: tuple[Any, ...] | None = None
    _job: str | None = None

    def start(
        self, fn: TaskFunction, key: str, factory: Callable[[], Any] | None, seed: int
    ) -> list[Any]:
        """The actors, started if needed and set up for a run (asynchronously: no waiting).

        Called before the driver times its probe tasks, so that the actors start, import and
        build the context meanwhile.
        """
        ray = connect(self.address, self.workers or os.cpu_count() or 1)
        # The actors belong to this driver's connection: after ray.shutdown() they are gone.
        context = ray.get_runtime_context()
        job = f"{context.gcs_address}/{context.get_node_id()}/{context.get_job_id()}"
        if self.actors and job != self._job:
            self.actors = []
        self._job = job
        if not self.actors:
            cpus = int(ray.cluster_resources().get("CPU", 1))
            wanted = max(1, min(self.workers or cpus, cpus))
            # an actor waits for a free CPU: one that never comes (every CPU held by another
            # executor's actors) would hang the run, so only free CPUs get actors
            free = _free_cpus(ray, wanted)
            if free < 1:
                raise BatchError(
                    f"the Ray cluster has no free CPU for this executor's workers: its {cpus} "
                    "CPUs are held by other actors (e.g. the workers of another Executor still "
                    "open: close() it, or use each executor in a with block)"
                )
            cls = _actor_class(ray)
            self.actors = [cls.remote() for _ in range(min(wanted, free))]
        # Each actor runs its calls in order: the set-up comes before the run's chunks. The
        # context is kept by key (worker_context), so a later run of the same one reuses it.
        self._run = (ray.put(fn), key, ray.put(factory), seed)
        for actor in self.actors:
            actor.setup.remote(*self._run)
        return self.actors

    def replace(self, index: int) -> Any:
        """A new actor, set up for the current run, in place of actor ``index`` (dead)."""
        ray = _ray()
        try:
            ray.kill(self.actors[index], no_restart=True)
        except Exception:  # already gone
            pass
        actor = _actor_class(ray).remote()
        if self._run is not None:
            actor.setup.remote(*self._run)
        self.actors[index] = actor
        return actor

    def discard(self) -> None:
        """Kill the actors (the next run starts new ones)."""
        actors, self.actors, self._run = self.actors, [], None
        if not actors:
            return
        try:
            import ray

            if not ray.is_initialized():
                return
            for actor in actors:
                ray.kill(actor, no_restart=True)
        except Exception:  # Ray already shut down: its actors went with it
            pass


FREE_CPU_WAIT = 2.0
"""How long a pool waits for the CPUs of actors just killed (Ray frees them asynchronously) [s]."""


def _free_cpus(ray: Any, wanted: int, wait: float = FREE_CPU_WAIT) -> int:
    """The CPUs of the cluster free now, waiting up to ``wait`` [s] for ``wanted`` of them."""
    deadline = time.monotonic() + wait
    while True:
        free = int(ray.available_resources().get("CPU", 0))
        if free >= wanted or time.monotonic() >= deadline:
            return free
        time.sleep(0.05)


PIPELINE = 2
"""Chunks sent to each actor at once: the next one waits in the actor's queue, so the actor
does not idle for the driver's round trip (about 1 ms, 5 ms under load) between chunks."""


def run_ray(
    fn: TaskFunction,
    key: str,
    factory: Callable[[], Any] | None,
    chunks: ChunkQueue,
    seed: int,
    workers: int,
    retries: int,
    pool: RayPool,
) -> Iterator[list[TaskRecord]]:
    """Yield each chunk's records as it finishes, in completion order.

    ``pool`` was started for this run (:meth:`RayPool.start`). Each actor has up to
    :data:`PIPELINE` chunks in flight. When an actor with several chunks dies, which one
    killed it is unknown (the one it ran, or one that had finished but whose records were
    lost with the process): they all become suspects, each run again alone on an actor, where
    a death is that chunk's fault (retried, then split, then reported). The driver blocks in
    ``ray.wait`` (no polling) and collects every chunk finished by then; an interruption
    (Ctrl-C, or the caller closing the generator) kills the actors.
    """
    del fn, key, factory, seed, workers  # set up on the pool's actors by pool.start
    ray = _ray()
    queue = chunks  # cut as the actors take them
    suspects: deque[Chunk] = deque()
    # per actor: the chunks sent to it, oldest first, and whether they run alone (suspects)
    sent: list[deque[tuple[Any, Chunk]]] = [deque() for _ in pool.actors]
    alone = [False] * len(pool.actors)
    in_flight: dict[Any, int] = {}  # ref -> actor index
    finished = False

    def submit(index: int, chunk: Chunk) -> None:
        chunk.attempts += 1
        ref = pool.actors[index].run.remote(chunk.tasks)
        sent[index].append((ref, chunk))
        in_flight[ref] = index

    def send() -> None:
        for index, pending in enumerate(sent):  # suspects first, each on an idle actor
            if suspects and not pending:
                alone[index] = True
                submit(index, suspects.popleft())
        for depth in range(1, PIPELINE + 1):  # then fill the others to depth 1, then 2, ...
            for index, pending in enumerate(sent):
                if not queue or suspects:
                    return
                if len(pending) < depth and not (pending and alone[index]):
                    alone[index] = False
                    submit(index, queue.popleft())

    try:
        while queue or suspects or in_flight:
            send()
            refs = list(in_flight)
            done, rest = ray.wait(refs, num_returns=1)
            if rest:  # whatever else finished meanwhile, without waiting
                more, _ = ray.wait(rest, num_returns=len(rest), timeout=0)
                done += more
            for ref in done:
                index = in_flight.pop(ref, None)
                if index is None:  # its actor died and its chunk was already dealt with
                    continue
                pending = sent[index]
                position = next(i for i, (r, _) in enumerate(pending) if r == ref)
                chunk = pending[position][1]
                try:
                    records = ray.get(ref)
                except ray.exceptions.RayActorError as exc:
                    if exc.actor_init_failed:  # not a task's fault: no worker can start
                        raise BatchError(
                            "the Ray workers could not start (is taskspace importable "
                            f"on every node, with the driver's version?): {_reason(exc)}"
                        ) from exc
                    pool.replace(index)
                    lost = [c for _, c in pending]
                    for other, _ in pending:
                        in_flight.pop(other, None)
                    pending.clear()
                    if len(lost) == 1:  # it ran alone: its fault
                        yield from _crashed(lost[0], exc, retries, suspects)
                    else:
                        suspects.extend(lost)
                except ray.exceptions.RayError as exc:  # e.g. the records could not be sent
                    del pending[position]
                    yield from _crashed(chunk, exc, retries, suspects)
                else:
                    del pending[position]
                    yield chunk.stamp(records)
        finished = True
    finally:
        if not finished:
            pool.discard()


def _crashed(
    chunk: Chunk, exc: BaseException, retries: int, suspects: deque[Chunk]
) -> Iterator[list[TaskRecord]]:
    """A chunk whose run failed in Ray on its own: retried first, then split, then reported."""
    if died := chunk.crashed_alone(retries, suspects, _reason(exc)):
        yield died
