"""A chunk: the tasks sent to a worker at once, and how often it was started."""

from __future__ import annotations

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
