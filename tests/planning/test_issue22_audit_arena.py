"""Issue #22 audit, item 7: the planner arena writes one database row per run and the plots.

Only the arena's cost-row summary was tested (``test_planning_audit_22.py``). Here the arena
itself runs every planner on the 2-D square problem (known optimum
``2 sqrt(0.3^2 + 0.2^2) + 0.2``) with a short budget into an in-memory SQLite database, and
the rows are checked against what a run must satisfy independently of the planners: one row
per (planner, seed), a cost only for successes and never below the analytic optimum, a
non-increasing cost over time whose last value is the run's cost; then ``plot`` draws one
readable, non-blank PNG per scenario.
"""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from benchmarks.suites import planner_arena as arena

OPTIMUM = 2 * math.hypot(0.3, 0.2) + 0.2
LIMIT = 0.05  # below the arena's 0.1 s checkpoint: no checkpoint rows
SEEDS = 2


@pytest.fixture(scope="module")
def db() -> sqlite3.Connection:
    problems = arena.square_2d()
    assert all(p.optimum == pytest.approx(OPTIMUM) for p in problems)
    conn = sqlite3.connect(":memory:")
    conn.executescript(arena.SCHEMA)
    arena.arena(problems, LIMIT, SEEDS, conn)
    return conn


def test_one_row_per_run_with_consistent_fields(db: sqlite3.Connection) -> None:
    rows = db.execute(
        "SELECT id, planner, seed, time_limit_s, success, cost, path_length, optimum FROM runs"
    ).fetchall()
    n_problems = len(arena.square_2d())
    assert len(rows) == len(arena.PLANNERS) * SEEDS * n_problems
    per = {}
    for _, planner, seed, limit, _, _, _, _ in rows:
        per[(planner, seed)] = per.get((planner, seed), 0) + 1
        assert limit == LIMIT
    assert set(per) == {(p, s) for p in arena.PLANNERS for s in range(SEEDS)}
    assert set(per.values()) == {n_problems}
    solved = 0
    for _, _, _, _, success, cost, length, optimum in rows:
        assert optimum == pytest.approx(OPTIMUM)
        if success:
            solved += 1
            assert cost >= OPTIMUM - 1e-9 and length >= OPTIMUM - 1e-9
        else:
            assert cost is None and length is None
    assert solved >= len(rows) // 2  # the square is easy: most runs solve it in 50 ms


def test_cost_over_time_only_improves_and_ends_at_the_runs_cost(db: sqlite3.Connection) -> None:
    runs = db.execute("SELECT id, success, cost FROM runs").fetchall()
    for run_id, success, cost in runs:
        prog = db.execute(
            "SELECT t_s, cost FROM progress WHERE run_id = ? ORDER BY rowid", (run_id,)
        ).fetchall()
        if not success:
            continue
        assert prog, run_id
        times = np.array([t for t, _ in prog])
        costs = np.array([c for _, c in prog])
        assert np.all(np.diff(times) >= 0.0) and np.all(np.diff(costs) <= 1e-12)
        assert costs[-1] == pytest.approx(cost)


@pytest.mark.slow  # matplotlib's import and a 4-panel figure: 3-8 s on the loaded machine
def test_plot_draws_one_readable_figure_per_scenario(
    db: sqlite3.Connection, tmp_path: Path
) -> None:
    import matplotlib.image

    files = arena.plot(db, tmp_path)
    scenarios = {r[0] for r in db.execute("SELECT DISTINCT scenario FROM runs")}
    assert {f.stem for f in files} == scenarios
    for f in files:
        image = matplotlib.image.imread(f)
        assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 400
        assert float(np.std(image[..., :3])) > 0.01  # not blank
