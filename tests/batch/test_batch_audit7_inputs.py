"""Batch inputs a new user gets wrong, and a task that calls ``sys.exit`` (no Ray needed).

* ``items=None`` (or any non-iterable) was a bare ``TypeError`` from ``list(items)``.
* ``SystemExit`` raised by a task (``sys.exit``, an argument parser) ended the whole run (and
  the serial backend's program) instead of failing its task as any exception does.
* ``seed=np.int64(3)`` was refused as "not an integer" while ``seed=True`` was accepted;
  ``min_chunk_seconds=True`` and ``ray_address=5`` were accepted.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pytest

from taskspace.batch import BatchOptions, BatchStatus, Executor, run_batch
from taskspace.errors import InvalidInputError


def exits_on_one(item: Any, rng: np.random.Generator, context: Any) -> int:
    if item == 1:
        sys.exit(3)
    return int(item) * 10


def draw(item: Any, rng: np.random.Generator, context: Any) -> float:
    return float(rng.random())


def exiting_context() -> None:
    raise SystemExit("no robot here")


@pytest.mark.parametrize("items", [None, 3, 2.5])
def test_items_that_are_not_iterable(items: Any) -> None:
    with Executor(BatchOptions(backend="serial", progress=False)) as ex:
        with pytest.raises(InvalidInputError, match=r"items must be an iterable.*got"):
            ex.map(draw, items)


# "fork": the workers run this tree's taskspace as the driver imported it
@pytest.mark.parametrize("backend", ["serial", "processes"])
def test_a_task_calling_sys_exit_fails_alone(backend: str) -> None:
    options = BatchOptions(backend=backend, workers=2, progress=False, start_method="fork")
    result = run_batch(exits_on_one, range(4), options=options)
    assert result.status is BatchStatus.PARTIAL
    [failure] = result.failures
    assert failure.index == 1 and failure.item == 1
    assert failure.error == "SystemExit(3)" and "sys.exit" in failure.traceback
    assert [r.value for r in result.records if r.ok] == [0, 20, 30]


def test_a_context_factory_calling_sys_exit_fails_the_tasks() -> None:
    options = BatchOptions(backend="serial", progress=False)
    result = run_batch(draw, range(2), context=exiting_context, options=options)
    assert [r.error for r in result.records] == [
        "context factory failed: SystemExit('no robot here')"
    ] * 2


def test_seeds_of_numpy_integers_are_integers() -> None:
    serial = BatchOptions(backend="serial", progress=False, seed=3)
    numpy_seed = BatchOptions(backend="serial", progress=False, seed=np.int64(3))  # type: ignore[arg-type]
    assert numpy_seed.seed == 3 and type(numpy_seed.seed) is int
    a = run_batch(draw, range(3), options=serial).values
    b = run_batch(draw, range(3), options=numpy_seed).values
    assert a == b


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("seed", True, "seed must be an integer >= 0"),
        ("seed", np.int64(-1), "seed must be an integer >= 0"),
        ("min_chunk_seconds", True, "min_chunk_seconds must be a number >= 0"),
        ("ray_address", 5, r"ray_address must be None.*'auto'.*got 5"),
    ],
)
def test_option_types(field: str, value: Any, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        BatchOptions(**{field: value})
