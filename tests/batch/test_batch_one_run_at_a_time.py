"""An executor runs one batch at a time: a second concurrent run is refused, not mixed in."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest

from taskspace.batch import BatchOptions, Executor
from taskspace.errors import ConcurrentUseError, TaskspaceError


def _square(x: int, rng: np.random.Generator, context: Any) -> int:
    return x * x


def _slow(x: int, rng: np.random.Generator, context: Any) -> int:
    threading.Event().wait(0.01)
    return x


def test_second_interleaved_stream_is_refused_and_first_finishes() -> None:
    ex = Executor(BatchOptions(backend="serial", progress=False))
    first = ex.as_completed(_square, range(5))
    assert next(first).value == 0
    second = ex.as_completed(_square, range(3))
    with pytest.raises(ConcurrentUseError, match="one run at a time") as info:
        next(second)
    assert isinstance(info.value, TaskspaceError)
    assert sorted(r.value for r in first) == [1, 4, 9, 16]
    # The first run is over: the executor takes the next one.
    assert ex.map(_square, range(4)).values == [0, 1, 4, 9]


def test_abandoned_stream_releases_the_executor() -> None:
    ex = Executor(BatchOptions(backend="serial", progress=False))
    stream = ex.as_completed(_square, range(5))
    next(stream)
    stream.close()
    assert ex.map(_square, range(3)).values == [0, 1, 4]


def test_run_from_a_second_thread_is_refused_while_one_runs() -> None:
    ex = Executor(BatchOptions(backend="serial", progress=False))
    started, errors = threading.Event(), []
    stream = ex.as_completed(_slow, range(20))
    next(stream)
    started.set()

    def other() -> None:
        try:
            ex.map(_square, range(3))
        except ConcurrentUseError as exc:
            errors.append(exc)

    t = threading.Thread(target=other)
    t.start()
    t.join()
    assert len(errors) == 1
    assert sorted(r.value for r in stream) == list(range(1, 20))
