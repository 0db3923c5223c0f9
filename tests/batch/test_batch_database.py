"""Campaign records in SQLite: one row per run, the values' keys as columns."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest

from taskspace.batch import BatchError, BatchOptions, TaskRecord, run_batch
from taskspace.batch.database import read_sqlite, write_sqlite


def _plan_like(item: int, rng: np.random.Generator, context: object) -> dict[str, object]:
    """What a planning task returns: scalars, a nested dict, an array, a NaN on failure."""
    if item == 3:
        raise ValueError("problem 3 is infeasible")
    found = bool(item % 2 == 0)
    return {
        "solved": found,
        "time": 0.001 * (item + 1),
        "cost": float(item) if found else float("nan"),
        "problem": {"scenario": "shelf" if item < 4 else "cage", "index": item},
        "path": np.arange(item, dtype=float),
    }


def test_rows_and_columns_answer_sql_like_the_records(tmp_path: Path) -> None:
    result = run_batch(
        _plan_like, range(8), options=BatchOptions(backend="serial", progress=False, retries=0)
    )
    db = write_sqlite(result, tmp_path / "bench.sqlite", experiment="rrt_connect")
    con = sqlite3.connect(db)
    cols = {r[1] for r in con.execute('PRAGMA table_info("runs")')}
    assert {"experiment", "task", "ok", "seconds", "solved", "time", "cost"} <= cols
    assert {"problem.scenario", "problem.index", "path", "error"} <= cols
    # SQL over the table equals the same statistics computed from the records.
    ok = [r for r in result.records if r.ok]
    got = con.execute(
        'SELECT "problem.scenario", COUNT(*), SUM(solved), AVG(time) FROM runs WHERE ok = 1 '
        'GROUP BY "problem.scenario" ORDER BY 1'
    ).fetchall()
    expect = []
    for scen in ("cage", "shelf"):
        rs = [r.value for r in ok if r.value["problem"]["scenario"] == scen]
        expect.append(
            (scen, len(rs), sum(v["solved"] for v in rs), np.mean([v["time"] for v in rs]))
        )
    assert [g[:3] for g in got] == [e[:3] for e in expect]
    assert [g[3] for g in got] == pytest.approx([e[3] for e in expect], rel=1e-15)
    # The failed run is a row with its error; NaN costs are NULL, not a wrong number.
    (err,) = con.execute("SELECT error FROM runs WHERE ok = 0").fetchone()
    assert "problem 3 is infeasible" in err
    nulls = con.execute("SELECT COUNT(*) FROM runs WHERE ok = 1 AND cost IS NULL").fetchone()[0]
    assert nulls == sum(1 for r in ok if not r.value["solved"])
    con.close()


def test_a_later_campaign_appends_rows_and_new_columns(tmp_path: Path) -> None:
    db = tmp_path / "b.sqlite"
    write_sqlite([TaskRecord(0, True, {"time": 0.5})], db, experiment="a")
    write_sqlite(
        [TaskRecord(0, True, {"time": 0.25, "cost": 2.0}), TaskRecord(1, True, 7)],
        db,
        experiment="b",
    )
    rows = read_sqlite(db)
    assert [(r["experiment"], r["time"], r["cost"]) for r in rows[:2]] == [
        ("a", 0.5, None),
        ("b", 0.25, 2.0),
    ]
    assert rows[2]["value"] == 7


def test_bad_table_names_and_missing_files_are_clear(tmp_path: Path) -> None:
    with pytest.raises(BatchError, match="identifier"):
        write_sqlite([], tmp_path / "x.sqlite", table="runs; DROP TABLE runs")
    with pytest.raises(BatchError, match="no database"):
        read_sqlite(tmp_path / "missing.sqlite")
    write_sqlite([TaskRecord(0, True, 1)], tmp_path / "y.sqlite")
    with pytest.raises(BatchError, match=r"no table 'other'.*runs"):
        read_sqlite(tmp_path / "y.sqlite", table="other")
