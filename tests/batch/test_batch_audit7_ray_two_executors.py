"""Two executors on one local Ray runtime whose CPUs the first one's actors hold.

The second executor's actors waited for a CPU that never came: its run hung without a word
(found by the new-user sweep of session 32). Now a pool starts actors only on free CPUs, and
raises a :class:`BatchError` naming the cause when there is none.
"""

from __future__ import annotations

import os
import re
import threading

import _batch_tasks as T
import pytest

from taskspace.batch import BatchError, BatchOptions, Executor

ray = pytest.importorskip("ray")
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")


def _options(workers: int) -> BatchOptions:
    return BatchOptions(backend="ray", workers=workers, progress=False)


def test_a_second_executor_without_free_cpus_raises_instead_of_hanging(local_ray: None) -> None:
    assert ray.cluster_resources()["CPU"] == 2
    first = Executor(_options(2))
    second = Executor(_options(2))
    try:
        assert first.map(T.noisy, range(4)).success  # its 2 actors hold the 2 CPUs
        outcome: list[BaseException | None] = []

        def run_second() -> None:
            try:
                second.map(T.noisy, range(4))
                outcome.append(None)
            except BaseException as exc:
                outcome.append(exc)

        thread = threading.Thread(target=run_second, daemon=True)
        thread.start()
        thread.join(60)
        hung = thread.is_alive()
        first.close()  # its CPUs come back: the second one runs (a hung run ends too)
        thread.join(60)
        assert not hung, "the second executor's run waited for CPUs held by the first"
        [error] = outcome
        assert isinstance(error, BatchError)
        assert re.search(r"no free CPU.*another Executor still open", str(error)), error
        assert second.map(T.noisy, range(4)).values == first_values()
    finally:
        first.close()
        second.close()


def test_executors_share_the_cpus(local_ray: None) -> None:
    with Executor(_options(1)) as one, Executor(_options(2)) as two:
        assert one.map(T.noisy, range(3)).success
        result = two.map(T.noisy, range(6))  # one CPU left: one actor
        assert result.success and len(two._actors.actors) == 1


def first_values() -> list[list[float]]:
    from taskspace.batch import run_batch

    return run_batch(
        T.noisy, range(4), options=BatchOptions(backend="serial", progress=False)
    ).values
