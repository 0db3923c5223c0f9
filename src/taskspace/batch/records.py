"""What a batch run returns and writes: one record per task, a result, a JSON Lines store.

Thread safety: :class:`TaskRecord` is immutable and :class:`BatchResult` plain data (not
locked: do not modify one while another thread reads it); :class:`BatchStatus` is an enum and
:class:`BatchError` an exception.
"""

from __future__ import annotations

import enum
import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from taskspace.errors import TaskspaceError


class BatchError(TaskspaceError):
    """A batch run could not be carried out, or some of its tasks failed.

    Attributes:
        failures: the records of the tasks that failed (input, error, traceback).
    """

    def __init__(self, message: str, failures: list[TaskRecord] | None = None) -> None:
        self.failures = list(failures or [])
        super().__init__(message)


class BatchStatus(enum.Enum):
    """How a batch run ended."""

    COMPLETE = "complete"  # every task returned a value
    PARTIAL = "partial"  # some tasks failed after their retries; the others returned


@dataclass(frozen=True)
class TaskRecord:
    """The outcome of one task.

    Attributes:
        index: position of the task's input in the input sequence.
        ok: True when the task function returned.
        value: what it returned (``None`` when it failed).
        error: ``repr`` of the exception, or why the worker died (empty when ``ok``).
        traceback: the worker-side traceback of the exception (empty when ``ok``).
        attempts: how many times the task was started (a retry after a worker death counts).
        seconds: wall time of the successful (or last) attempt inside the worker [s].
        resumed: True when the record was read back from an earlier run's results file.
        item: the task's input, kept on failed records so the failure can be reproduced.
    """

    index: int
    ok: bool
    value: Any = None
    error: str = ""
    traceback: str = ""
    attempts: int = 1
    seconds: float = 0.0
    resumed: bool = False
    item: Any = None

    def to_json(self) -> dict[str, Any]:
        """The record as a JSON-ready dictionary (the input is kept only for failures)."""
        out: dict[str, Any] = {
            "index": self.index,
            "ok": self.ok,
            "value": _jsonable(self.value),
            "attempts": self.attempts,
            "seconds": self.seconds,
        }
        if not self.ok:
            out.update(error=self.error, traceback=self.traceback, item=_jsonable(self.item))
        return out


@dataclass(frozen=True)
class BatchResult:
    """Records of every task of a run, in input order.

    Attributes:
        records: one record per input, ordered by index.
        status: COMPLETE when every task returned, PARTIAL otherwise.
        backend: the backend that ran the tasks.
        workers: the number of worker processes.
        chunk_size: the number of tasks sent to a worker at once (automatic chunks: the most).
        seconds: wall time of the whole run [s].
        n_resumed: how many records were read back from the results file instead of run.
    """

    records: list[TaskRecord]
    backend: str
    workers: int
    chunk_size: int
    seconds: float
    n_resumed: int = 0
    status: BatchStatus = field(init=False)

    def __post_init__(self) -> None:
        ok = all(r.ok for r in self.records)
        object.__setattr__(self, "status", BatchStatus.COMPLETE if ok else BatchStatus.PARTIAL)

    @property
    def success(self) -> bool:
        """True when every task returned a value."""
        return self.status is BatchStatus.COMPLETE

    @property
    def failures(self) -> list[TaskRecord]:
        """Records of the tasks that failed after their retries."""
        return [r for r in self.records if not r.ok]

    @property
    def values(self) -> list[Any]:
        """Every task's value in input order.

        Raises:
            BatchError: if a task failed (the error lists the failed inputs).
        """
        if not self.success:
            first = self.failures[0]
            raise BatchError(
                f"{len(self.failures)} of {len(self.records)} tasks failed; first: task "
                f"{first.index} with input {first.item!r}: {first.error}",
                self.failures,
            )
        return [r.value for r in self.records]


def _jsonable(x: Any) -> Any:
    """``x`` with NumPy arrays and scalars turned into lists and Python numbers."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    return x


class ResultsFile:
    """An append-only JSON Lines file of task records, read back to resume a run.

    Each line is one record (``{"index", "ok", "value", ...}``), flushed and synced as soon as
    the task finishes, so an interrupted run loses at most the tasks in flight. The first line
    is a header that names the run (its number of tasks and seed): resuming with other inputs
    is refused rather than mixing two runs in one file.
    """

    def __init__(self, path: str | os.PathLike[str], header: dict[str, Any]) -> None:
        self.path = Path(path)
        self.header = header
        self._fh: Any = None

    def load(self) -> dict[int, TaskRecord]:
        """Records already in the file (successful ones only; failures are run again).

        Raises:
            BatchError: if the file belongs to another run or a line is not valid JSON.
        """
        if not self.path.exists():
            return {}
        done: dict[int, TaskRecord] = {}
        with self.path.open() as fh:
            for lineno, line in enumerate(fh, 1):
                if not line.strip():
                    continue
                try:
                    row = json.loads(line)
                except json.JSONDecodeError as exc:
                    if lineno > 1 and not line.endswith("\n"):
                        break  # a line cut by an interruption: that task runs again
                    raise BatchError(f"{self.path}:{lineno}: not a JSON line ({exc})") from exc
                if lineno == 1:
                    if row.get("header") != self.header:
                        raise BatchError(
                            f"{self.path} holds results of another run ({row.get('header')}); "
                            f"this run is {self.header}: choose another file or delete it"
                        )
                    continue
                if row.get("ok"):
                    i = int(row["index"])
                    done[i] = TaskRecord(
                        index=i,
                        ok=True,
                        value=row["value"],
                        attempts=int(row.get("attempts", 1)),
                        seconds=float(row.get("seconds", 0.0)),
                        resumed=True,
                    )
        return done

    def open(self) -> None:
        """Open for appending; write the header when the file is new or empty."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        new = not self.path.exists() or self.path.stat().st_size == 0
        self._fh = self.path.open("a")
        if new:
            self._write({"header": self.header})

    def _write(self, row: dict[str, Any]) -> None:
        self._fh.write(json.dumps(row) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, records: Iterable[TaskRecord]) -> None:
        """Write finished records."""
        for r in records:
            self._write(r.to_json())

    def close(self) -> None:
        """Close the file."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None


def roundtrip(value: Any) -> Any:
    """``value`` as it reads back from a results file (arrays become lists)."""
    return json.loads(json.dumps(_jsonable(value)))


def iter_records(path: str | os.PathLike[str]) -> Iterator[dict[str, Any]]:
    """The task rows of a results file (the header line skipped)."""
    with Path(path).open() as fh:
        for line in fh:
            row = json.loads(line)
            if "header" not in row:
                yield row
