"""A chunk: the tasks sent to a worker at once, and how often it was started."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

from taskspace.batch.records import TaskRecord


@dataclass
class Chunk:
    """Tasks ``(index, item)`` run together by one worker.

    Attributes:
        tasks: the ``(index, item)`` pairs.
        attempts: how many times the chunk was started.
        crashes: how many times its worker died while it ran alone (attributable crashes).
    """

    tasks: list[tuple[int, Any]]
    attempts: int = 0
    crashes: int = 0

    def split(self) -> list[Chunk]:
        """One chunk per task, each remembering the attempts made so far."""
        return [Chunk([t], attempts=self.attempts) for t in self.tasks]

    def stamp(self, records: list[TaskRecord]) -> list[TaskRecord]:
        """``records`` with this chunk's attempt count."""
        return [
            r if r.attempts == self.attempts else replace(r, attempts=self.attempts)
            for r in records
        ]

    def crashed_alone(self, retries: int, suspects: deque[Chunk], reason: str) -> list[TaskRecord]:
        """Count a crash of this chunk's worker while it ran alone (its own fault).

        Retried first (back at the front of ``suspects``) while ``crashes <= retries``, then
        split into single tasks; a single task that keeps crashing gets failure records
        (returned; an empty list otherwise).
        """
        self.crashes += 1
        if self.crashes <= retries:
            suspects.appendleft(self)
        elif len(self.tasks) > 1:
            suspects.extendleft(reversed(self.split()))
        else:
            return self.died(reason)
        return []

    def died(self, reason: str) -> list[TaskRecord]:
        """Failure records for every task of a chunk whose worker kept dying."""
        return self.failed(f"worker died: {reason}")

    def failed(self, error: str) -> list[TaskRecord]:
        """Failure records with ``error`` for every task of the chunk."""
        return [
            TaskRecord(i, False, error=error, attempts=self.attempts, item=x) for i, x in self.tasks
        ]


def make_chunks(tasks: list[tuple[int, Any]], size: int, taper: int = 0) -> list[Chunk]:
    """Consecutive chunks of ``size`` tasks, smaller toward the end when ``taper`` > 0.

    With ``taper`` workers, a chunk holds at most ``ceil(remaining / (2 * taper))`` tasks
    (guided self-scheduling, capped at ``size``): the last chunks shrink to single tasks, so
    that the workers finish together instead of one running a whole chunk while the others
    idle. Which tasks a chunk holds never changes their values (seeds are per task).
    """
    if taper <= 0:
        return [Chunk(tasks[i : i + size]) for i in range(0, len(tasks), size)]
    chunks = []
    start = 0
    while start < len(tasks):
        remaining = len(tasks) - start
        n = max(1, min(size, -(-remaining // (2 * taper))))
        chunks.append(Chunk(tasks[start : start + n]))
        start += n
    return chunks


class ChunkQueue:
    """The chunks of a run, cut when a worker takes one, sized from the tasks' own times.

    With a fixed ``size`` every chunk holds ``size`` tasks. Without one (``size=None``), the
    first chunks hold one task each; each record that comes back (:meth:`observe`) gives a
    task time, and later chunks hold ``ceil(least_seconds / fastest task)`` tasks, capped at
    ``ceil(tasks / (4 * workers))`` and tapered toward the end as :func:`make_chunks` does
    (guided self-scheduling). The times come from the workers themselves, so the driver runs
    no task and builds no context to size the chunks. Which tasks a chunk holds never changes
    their values (seeds are per task).

    Attributes:
        largest: the most tasks cut into one chunk so far.
    """

    def __init__(
        self,
        tasks: list[tuple[int, Any]],
        size: int | None,
        workers: int,
        least_seconds: float,
    ) -> None:
        self._tasks = tasks
        self._start = 0
        self._fixed = size
        self._workers = max(1, workers)
        self._least = least_seconds
        self._cap = max(1, -(-len(tasks) // (4 * self._workers)))
        self._fastest = math.inf
        self.largest = 0

    def __bool__(self) -> bool:
        return self._start < len(self._tasks)

    def __len__(self) -> int:
        """Tasks not yet cut into a chunk."""
        return len(self._tasks) - self._start

    @property
    def size(self) -> int:
        """The size of the next full chunk (before the taper)."""
        if self._fixed is not None:
            return self._fixed
        if not math.isfinite(self._fastest):
            return 1
        return max(1, min(math.ceil(self._least / max(self._fastest, 1e-7)), self._cap))

    def observe(self, records: list[TaskRecord]) -> None:
        """Take the task times of finished records into account for the next chunks."""
        for r in records:  # failures may not have run (a dead worker): ok records only
            if r.ok and not r.resumed and 0 < r.seconds < self._fastest:
                self._fastest = r.seconds

    def popleft(self) -> Chunk:
        """The next chunk (the queue must not be empty)."""
        if not self:
            raise IndexError("popleft from an empty ChunkQueue")
        n = self.size
        if self._fixed is None:
            remaining = len(self)
            n = max(1, min(n, -(-remaining // (2 * self._workers))))
        chunk = Chunk(self._tasks[self._start : self._start + n])
        self._start += n
        self.largest = max(self.largest, len(chunk.tasks))
        return chunk
