"""The Ray backend: the same chunks as Ray tasks, on a local Ray runtime or a cluster.

``address=None`` starts a local runtime with ``workers`` CPUs (``ray.init(num_cpus=...)``);
``"auto"`` joins the cluster that ``ray start --head`` started on this machine (with several
clusters running Ray picks one: pass its ``"HOST:PORT"`` to be sure), and
``"ray://host:10001"`` a remote one; with no address, Ray's own ``RAY_ADDRESS`` environment
variable is honoured. Ray re-runs a task whose worker died (``max_retries``);
a chunk that still fails is split into single tasks, and a single task that keeps killing its
worker is reported as failed with its input.
"""

from __future__ import annotations

import os
import re
import sys
from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

from taskspace.batch.chunk import Chunk
from taskspace.batch.records import BatchError, TaskRecord
from taskspace.batch.worker import TaskFunction, run_chunk


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
        if address is None:
            # As a forked worker would: what the driver can import, the workers can.
            kwargs["num_cpus"] = workers
            kwargs["runtime_env"] = {"env_vars": {"PYTHONPATH": _driver_path()}}
        else:
            kwargs = {"address": address, "log_to_driver": False}
        try:
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


def run_ray(
    fn: TaskFunction,
    key: str,
    factory: Callable[[], Any] | None,
    chunks: list[Chunk],
    seed: int,
    workers: int,
    retries: int,
    address: str | None = None,
) -> Iterator[list[TaskRecord]]:
    """Yield each chunk's records as it finishes, in completion order."""
    ray = connect(address, workers)
    remote = ray.remote(max_retries=retries, retry_exceptions=False)(run_chunk)
    fn_ref, factory_ref = ray.put(fn), ray.put(factory)
    queue: deque[Chunk] = deque(chunks)
    in_flight: dict[Any, Chunk] = {}
    limit = 2 * max(1, int(ray.available_resources().get("CPU", workers)))
    try:
        while queue or in_flight:
            while queue and len(in_flight) < limit:
                chunk = queue.popleft()
                chunk.attempts += 1
                in_flight[remote.remote(fn_ref, key, factory_ref, chunk.tasks, seed)] = chunk
            done, _ = ray.wait(list(in_flight), num_returns=1)
            for ref in done:
                chunk = in_flight.pop(ref)
                try:
                    records = ray.get(ref)
                except ray.exceptions.RayError as exc:
                    chunk.crashes += 1
                    if len(chunk.tasks) > 1:
                        queue.extendleft(reversed(chunk.split()))
                    else:
                        yield chunk.died(_reason(exc))
                    continue
                yield chunk.stamp(records)
    finally:
        for ref in in_flight:
            ray.cancel(ref, force=True)
