"""The Ray backend sends each actor two chunks at once: a death is blamed only when alone."""

from __future__ import annotations

import os
from pathlib import Path

import _batch_tasks as T
import pytest

from taskspace.batch import BatchOptions, run_batch
from taskspace.batch.ray_backend import PIPELINE

ray = pytest.importorskip("ray")
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")


def _ray(**kw: object) -> BatchOptions:
    return BatchOptions(backend="ray", progress=False, workers=2, **kw)  # type: ignore[arg-type]


def test_the_chunk_queued_behind_a_dying_one_is_not_blamed(local_ray: None) -> None:
    assert PIPELINE >= 2  # else this test checks nothing new
    # item 7 kills its actor every time it starts, and often takes with it the records of
    # the chunk its actor ran just before (not yet sent back): only 7 may be reported
    for _ in range(3):
        result = run_batch(T.always_dies, range(16), options=_ray(chunk_size=1, retries=1))
        assert [r.index for r in result.failures] == [7]
        assert "worker died" in result.failures[0].error
        ok = [r for r in result.records if r.ok]
        assert [r.value for r in ok] == [i for i in range(16) if i != 7]


def test_a_killed_actor_with_two_chunks_in_flight_loses_no_result(
    local_ray: None, tmp_path: Path
) -> None:
    items = [(i, str(tmp_path)) for i in range(30)]
    result = run_batch(T.dies_once, items, options=_ray(chunk_size=3))
    assert (tmp_path / "died-5").exists()
    assert result.values == [i + 100 for i in range(30)]
    # the chunk of item 5 (items 3-5) ran again; chunks that never met a death ran once
    assert {3, 4, 5} <= {r.index for r in result.records if r.attempts >= 2}
    assert sum(r.attempts == 1 for r in result.records) >= 30 - 3 * PIPELINE
