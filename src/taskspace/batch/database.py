"""A campaign's records as an SQLite database: one row per run, one column per measured value.

This is the layout of OMPL's benchmark databases (a ``runs`` table whose columns are the
properties each run reports), so the same SQL answers "median time per planner and scenario"
whatever produced the runs. The values of the task functions become columns when they are
dictionaries of scalars (nested dictionaries are flattened with ``.``); anything else is stored
as JSON text in a ``value`` column.
"""

from __future__ import annotations

import json
import math
import os
import re
import sqlite3
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from taskspace.batch.records import BatchError, BatchResult, TaskRecord, _jsonable

_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_FIXED = {
    "experiment": "TEXT",
    "task": "INTEGER",
    "ok": "INTEGER",
    "attempts": "INTEGER",
    "seconds": "REAL",
    "error": "TEXT",
}


def _flatten(value: Any, prefix: str, out: dict[str, Any]) -> None:
    if isinstance(value, Mapping):
        for key, v in value.items():
            _flatten(v, f"{prefix}.{key}" if prefix else str(key), out)
        return
    v = _jsonable(value)
    if isinstance(v, bool):
        out[prefix] = int(v)
    elif isinstance(v, int | float | str) or v is None:
        out[prefix] = None if isinstance(v, float) and not math.isfinite(v) else v
    else:
        out[prefix] = json.dumps(v)


def _row(record: TaskRecord, experiment: str) -> dict[str, Any]:
    row: dict[str, Any] = {
        "experiment": experiment,
        "task": record.index,
        "ok": int(record.ok),
        "attempts": record.attempts,
        "seconds": record.seconds,
        "error": record.error,
    }
    values: dict[str, Any] = {}
    if isinstance(record.value, Mapping):
        _flatten(record.value, "", values)
    elif record.value is not None:
        _flatten(record.value, "value", values)
    for key, v in values.items():
        row[key if key not in _FIXED else f"value.{key}"] = v
    return row


def _sql_type(v: Any) -> str:
    if isinstance(v, int):
        return "INTEGER"
    if isinstance(v, float):
        return "REAL"
    return "TEXT"


def write_sqlite(
    records: BatchResult | Iterable[TaskRecord],
    path: str | os.PathLike[str],
    *,
    experiment: str = "",
    table: str = "runs",
) -> Path:
    """Append a campaign's records to an SQLite database, one row per task.

    Columns: ``experiment``, ``task`` (input index), ``ok``, ``attempts``, ``seconds`` (wall
    time in the worker [s]), ``error``, then one column per key of the tasks' dictionary values
    (nested keys joined with ``.``; non-finite floats stored as NULL). Columns that a later run
    adds are appended to the table.

    Args:
        records: a :class:`BatchResult` or its records.
        path: the database file (created when missing).
        experiment: a label stored in every row (e.g. the planner or the campaign's name).
        table: the table name (an SQL identifier).

    Returns:
        The database path.

    Raises:
        BatchError: for a table name that is not an identifier or an unwritable file.
    """
    if not _IDENTIFIER.match(table):
        raise BatchError(f"table name {table!r} is not an SQL identifier (letters, digits, _)")
    recs = records.records if isinstance(records, BatchResult) else list(records)
    rows = [_row(r, experiment) for r in recs]
    columns: dict[str, str] = dict(_FIXED)
    for row in rows:
        for key, v in row.items():
            if key not in columns and v is not None:
                columns[key] = _sql_type(v)
    for row in rows:  # columns whose every value is NULL
        for key in row:
            columns.setdefault(key, "TEXT")
    out = Path(path)
    try:
        con = sqlite3.connect(out)
    except sqlite3.Error as exc:
        raise BatchError(f"cannot open the database {out}: {exc}") from exc
    try:
        with con:
            con.execute(
                f'CREATE TABLE IF NOT EXISTS "{table}" (id INTEGER PRIMARY KEY AUTOINCREMENT)'
            )
            have = {r[1] for r in con.execute(f'PRAGMA table_info("{table}")')}
            for key, kind in columns.items():
                if key not in have:
                    quoted = key.replace('"', '""')
                    con.execute(f'ALTER TABLE "{table}" ADD COLUMN "{quoted}" {kind}')
            for row in rows:
                keys = list(row)
                names = ", ".join('"' + k.replace('"', '""') + '"' for k in keys)
                marks = ", ".join("?" for _ in keys)
                con.execute(
                    f'INSERT INTO "{table}" ({names}) VALUES ({marks})', [row[k] for k in keys]
                )
    except sqlite3.Error as exc:
        raise BatchError(f"cannot write the table {table!r} of {out}: {exc}") from exc
    finally:
        con.close()
    return out


def read_sqlite(path: str | os.PathLike[str], *, table: str = "runs") -> list[dict[str, Any]]:
    """The rows of a table written by :func:`write_sqlite`, as dictionaries.

    Raises:
        BatchError: for a missing file or table.
    """
    if not _IDENTIFIER.match(table):
        raise BatchError(f"table name {table!r} is not an SQL identifier (letters, digits, _)")
    p = Path(path)
    if not p.is_file():
        raise BatchError(f"no database at {p}")
    con = sqlite3.connect(p)
    try:
        con.row_factory = sqlite3.Row
        tables = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")]
        if table not in tables:
            raise BatchError(f"{p} has no table {table!r}; tables: {sorted(tables)}")
        return [dict(r) for r in con.execute(f'SELECT * FROM "{table}" ORDER BY id')]
    finally:
        con.close()
