"""Issue #22 item 7: the planner arena runs in full and leaves a usable database when cut short.

* OMPL planners the peer's bindings lack (OMPL 2.0.1 has no LazyPRMstar) are reported as
  "not available in OMPL <version>" in the table and in the database (table ``planners``),
  not dropped silently; the real peer's header names every planner it was asked for.
* The full arena lists every MotionBenchMaker problem on disk (all seven scenarios).
* A Ctrl-C keeps the problems finished (both sides), says where it stopped (``meta``), and
  the table and figures are drawn from the partial database; a peer that dies stops only its
  own runs; a planner that raises leaves a row of status ``error``.

The peer is replaced by a small script speaking the same protocol (stdlib only), so these
tests run without OMPL; the real peer's header is checked when its environment exists.
"""

from __future__ import annotations

import json
import math
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from benchmarks.common import ROOT, peer_python
from benchmarks.suites import planner_arena as arena
from taskspace.planning.scene_loader import MOTIONBENCHMAKER_SCENARIOS
from tests.planning._mbm import ROOT as MBM_ROOT

LIMIT = 0.05  # below the arena's 0.1 s checkpoint: no checkpoint rows

FAKE_PEER = """
import json, sys
fail_at = int(sys.argv[1])
print("a line that is not JSON", flush=True)
print(json.dumps({"ompl_version": "9.9.9", "planners": ["ompl RRTConnect"],
                  "missing": ["LazyPRMstar"]}), flush=True)
for line in sys.stdin:
    k = json.loads(line)["k"]
    if k == fail_at:
        print(json.dumps({"run": {"planner": "ompl RRTConnect", "scenario": "square_2d",
              "problem": k, "seed": 0, "success": True, "time_s": 0.01, "cost": 1.0,
              "time_limit_s": 0.05}}), flush=True)
        sys.stderr.write("peer crashed: no more runs\\n")
        sys.exit(3)
    print(json.dumps({"run": {"planner": "ompl RRTConnect", "scenario": "square_2d",
          "problem": k, "seed": 0, "success": True, "time_s": 0.01, "cost": 1.0,
          "time_limit_s": 0.05}}), flush=True)
    print(json.dumps({"done": k}), flush=True)
"""


def _fake_peer(tmp_path: Path, fail_at: int = -1) -> arena.OmplPeer:
    script = tmp_path / "fake_peer.py"
    script.write_text(FAKE_PEER)
    return arena.OmplPeer([sys.executable, str(script), str(fail_at)])


def _squares(n: int) -> list[arena.Problem]:
    """``n`` copies of the 2-D square problem, numbered 0..n-1."""
    base = arena.square_2d()[0]
    return [
        arena.Problem("square_2d", i, base.space, base.start, base.goal, base.optimum)
        for i in range(n)
    ]


def _db() -> sqlite3.Connection:
    db = sqlite3.connect(":memory:")
    db.executescript(arena.SCHEMA)
    return db


def _meta(db: sqlite3.Connection) -> dict[str, str]:
    return dict(db.execute("SELECT key, value FROM meta").fetchall())


def test_missing_ompl_planners_are_reported(tmp_path: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(arena, "problem_specs", lambda quick: [
        arena.ProblemSpec(p.scenario, p.index, lambda p=p: p) for p in _squares(1)
    ])  # fmt: skip
    monkeypatch.setattr(arena, "start_peer", lambda *a: (_fake_peer(tmp_path), ""))
    monkeypatch.setattr(arena, "PLANNERS", {"rrt_connect": arena.PLANNERS["rrt_connect"]})
    monkeypatch.setenv("TASKSPACE_ARENA_TIME", str(LIMIT))
    monkeypatch.setenv("TASKSPACE_ARENA_SEEDS", "1")
    rows = arena.run(quick=True, out=tmp_path)
    missing = [r for r in rows if r.method == "ompl LazyPRMstar"]
    assert len(missing) == 1 and missing[0].note == "not available in OMPL 9.9.9"
    db = sqlite3.connect(tmp_path / "planner_arena.db")
    planners = {p: (a, n) for p, a, n in db.execute("SELECT * FROM planners")}
    assert planners["ompl LazyPRMstar"] == (0, "not available in OMPL 9.9.9")
    assert planners["ompl RRTConnect"] == (1, "OMPL 9.9.9")
    assert planners["rrt_connect"] == (1, "taskspace")
    ran = {p for (p,) in db.execute("SELECT DISTINCT planner FROM runs")}
    assert ran == {"rrt_connect", "ompl RRTConnect"}
    assert _meta(db)["status"] == "complete" and (tmp_path / "square_2d.png").is_file()


@pytest.mark.skipif(peer_python("ompl") is None, reason="OMPL peer environment not installed")
def test_the_ompl_peer_names_every_planner() -> None:
    out = subprocess.run(
        [str(peer_python("ompl")), str(ROOT / "benchmarks/peers/ompl_arena.py"), "--header"],
        capture_output=True, text=True, timeout=120, check=True,
    )  # fmt: skip
    header = json.loads(out.stdout.strip().splitlines()[-1])
    asked = {"RRTstar", "InformedRRTstar", "PRMstar", "LazyPRMstar", "BITstar", "RRTConnect"}
    ran = {name.removeprefix("ompl ") for name in header["planners"]}
    assert ran | set(header["missing"]) == asked and not ran & set(header["missing"])
    assert header["ompl_version"] not in ("", "unknown")


@pytest.mark.skipif(MBM_ROOT is None, reason="MotionBenchMaker files not present")
def test_the_full_arena_lists_every_motionbenchmaker_problem(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.delenv("TASKSPACE_ARENA_PROBLEMS", raising=False)
    monkeypatch.delenv("TASKSPACE_ARENA_SCENARIOS", raising=False)
    assert MBM_ROOT is not None
    on_disk = {
        (f"mbm_{s}", int(f.stem[7:]))
        for s in MOTIONBENCHMAKER_SCENARIOS
        for f in (MBM_ROOT / f"{s}_panda").glob("request*.yaml")
    }
    listed = {(p.scenario, p.index) for p in arena.problem_specs(quick=False)}
    assert {x for x in listed if x[0].startswith("mbm_")} == on_disk
    assert len(on_disk) == 350
    # built one at a time on one Panda (a robot per problem kept ~70 MB each: 350 did not fit)
    mbm = [p for p in arena.problem_specs(quick=False) if p.scenario.startswith("mbm_")]
    for spec in mbm[:3]:
        problem = spec.build()
        assert problem is not None and problem.space.is_valid(problem.goal)
        assert len(arena._PANDA) == 1 and problem.space.checker.robot is arena._PANDA[0]
    monkeypatch.setenv("TASKSPACE_ARENA_SCENARIOS", "box,kitchen")
    with pytest.raises(ValueError, match="unknown \\['kitchen'\\]; scenarios are: bookshelf"):
        arena.problem_specs(quick=False)


def test_ctrl_c_keeps_the_problems_finished(monkeypatch, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    def interrupted(p: arena.Problem, t: float, s: int) -> Any:
        if p.index == 2:
            raise KeyboardInterrupt
        return arena.PLANNERS["rrt_connect"](p, t, s)

    def broken(p: arena.Problem, t: float, s: int) -> Any:
        raise RuntimeError("a planner bug")

    planners = {"rrt_connect": arena.PLANNERS["rrt_connect"], "broken": broken,
                "interrupted": interrupted}  # fmt: skip
    monkeypatch.setattr(arena, "PLANNERS", planners)
    db = _db()
    notes = arena.arena(_squares(4), LIMIT, 2, db, peer=_fake_peer(tmp_path))
    assert notes[0] == "interrupted (Ctrl-C) after 2 of 4 problems"
    assert notes[1].startswith("4 runs raised (status 'error'), first: broken on square_2d 0")
    meta = _meta(db)
    assert meta["status"] == "interrupted" and meta["problems_done"] == "2"
    rows = db.execute("SELECT planner, problem, status FROM runs").fetchall()
    # problems 0 and 1 whole (both sides), nothing of problem 2 (dropped), nor after
    assert {r[1] for r in rows} == {0, 1}
    for problem in (0, 1):
        mine = [r for r in rows if r[1] == problem]
        assert sorted(r[0] for r in mine) == sorted(
            [*(["rrt_connect", "broken", "interrupted"] * 2), "ompl RRTConnect"]
        )
        assert all((r[2] == "error") == (r[0] == "broken") for r in mine)
    table = {(r.scene, r.method): r for r in arena.table(db)}
    assert table[("square_2d", "rrt_connect")].extra["runs"] == 4
    assert table[("square_2d", "broken")].extra["success"] == 0.0
    assert [f.name for f in arena.plot(db, tmp_path)] == ["square_2d.png"]


def test_a_failing_peer_stops_only_its_runs(tmp_path: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(arena, "PLANNERS", {"rrt_connect": arena.PLANNERS["rrt_connect"]})
    db = _db()
    notes = arena.arena(_squares(3), LIMIT, 1, db, peer=_fake_peer(tmp_path, fail_at=1))
    assert len(notes) == 1 and notes[0].startswith("OMPL peer failed (its runs stop at problem 1)")
    assert "peer crashed: no more runs" in notes[0]  # its stderr says why
    meta = _meta(db)
    assert meta["status"] == "complete" and meta["problems_done"] == "3"
    assert meta["peer"] == notes[0]
    runs = db.execute("SELECT planner, problem, success, cost FROM runs").fetchall()
    assert sorted(r[1] for r in runs if r[0] == "rrt_connect") == [0, 1, 2]
    # the peer's runs: problem 0, and the one it sent before dying in problem 1
    assert sorted(r[1] for r in runs if r[0] == "ompl RRTConnect") == [0, 1]
    assert all(r[3] is None or math.isfinite(r[3]) for r in runs)
