"""The planning suite's rows: a first plan on each new scene, then the repeated plans.

``benchmarks/suites/planning.py`` plans every MotionBenchMaker problem with several
configurations on the same scene; only the first of them pays for a new scene. These tests
check that the headline configuration plans first (its row ``..._first_plan``), right after
the timed scene set-up, and that the set-up row stays out of the planners' ratios. No timing
is asserted: speed lives in the suite's output.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from taskspace.model import Robot
from taskspace.planning.rrt_connect import rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda
from tests.planning._mbm import ROOT, SKIP_REASON, reference_free

pytestmark = pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)

HEADLINE = "rrt_connect_spheres_only_validator_spheres"


@pytest.fixture(scope="module")
def suite() -> ModuleType:
    """``benchmarks.suites.planning``, imported with the problems' directory set."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TASKSPACE_MOTIONBENCHMAKER_DIR", str(ROOT))
        return importlib.import_module("benchmarks.suites.planning")


@pytest.fixture(scope="module")
def robot() -> Robot:
    return motionbenchmaker_panda()


@pytest.mark.parametrize(("scenario", "index"), [("table_pick", 1), ("bookshelf_small", 2)])
def test_first_plan_is_the_headline_planned_before_the_mesh_row(
    suite: ModuleType, robot: Robot, monkeypatch: pytest.MonkeyPatch, scenario: str, index: int
) -> None:
    calls: list[tuple[str, str, bool, Any]] = []
    seeds: list[int] = []

    def recording(space: Any, start: Any, goal: Any, options: Any) -> Any:
        res = rrt_connect(space, start, goal, options)
        calls.append((options.checker, options.validator, options.native, res))
        seeds.append(options.seed)
        return res

    monkeypatch.setattr(suite, "rrt_connect", recording)
    # problem number k = 1: no checker-cost sampling; not quick: no PRM
    out = suite._plan_problem((scenario, index, 1, False), np.random.default_rng(0), robot)
    assert "invalid" not in out
    per = out["samples"]

    setup = per["scene_setup"]
    assert np.isfinite(setup["time"]) and setup["time"] > 0.0
    first = per[f"{HEADLINE}_first_plan"]
    assert first["ok"] == 1.0
    assert np.isfinite(first["time"]) and first["time"] > 0.0

    # The first planner call on the new scene is the headline configuration; the exact
    # checker's row (first before this row existed) comes after it.
    order = [(checker, validator, native) for checker, validator, native, _ in calls]
    assert order[0] == ("spheres_only", "spheres", True)
    assert ("mesh", "mesh", True) in order[1:]
    # every configuration once, the headline MIN_OF times in a row (its min row), then MIN_OF
    # times with each other seed of the seeds row
    extra = (len(suite.SEED_OFFSETS) - 1) * suite.MIN_OF
    assert len(calls) == len(suite.RRT_CONFIGURATIONS) + suite.MIN_OF - 1 + extra
    at = order.index(("spheres_only", "spheres", True), 1)
    assert order[at : at + suite.MIN_OF] == [("spheres_only", "spheres", True)] * suite.MIN_OF

    # The same seeded plan as the headline's repeated row: the same checks and path.
    repeated = per[HEADLINE]
    assert first["checks"] == repeated["checks"]
    assert first["length"] == pytest.approx(repeated["length"], rel=1e-12)

    # The min row: the same plan (checks, length) at its least wall time of the repeats.
    assert suite.HEADLINE_MIN in suite.METHODS
    assert f"taskspace {suite.HEADLINE_MIN}" in suite.OURS_RRT
    least = per[suite.HEADLINE_MIN]
    assert least["checks"] == repeated["checks"]
    assert least["length"] == repeated["length"]
    assert 0.0 < least["time"] <= repeated["time"]
    repeats = [res for _, _, _, res in calls[at : at + suite.MIN_OF]]
    assert all(r.collision_checks == repeated["checks"] for r in repeats)
    assert least["time_s"] == min(r.time_s for r in repeats)

    # The seeds row: right after the min row's calls, MIN_OF calls per other seed k + offset
    # (same options otherwise), the problem solved with each seed.
    seeded = calls[at + suite.MIN_OF : at + suite.MIN_OF + extra]
    assert [c[:3] for c in seeded] == [("spheres_only", "spheres", True)] * extra
    assert [seeds[at + suite.MIN_OF + j] for j in range(extra)] == [
        1 + offset for offset in suite.SEED_OFFSETS[1:] for _ in range(suite.MIN_OF)
    ]
    spread = per[suite.HEADLINE_SEEDS]
    assert spread["ok"] == 1.0 and all(c[3].success for c in seeded)
    assert spread["time"] >= min(r.time_s for r in [*repeats, *(s[3] for s in seeded)])
    assert spread["time"] < np.inf
    assert f"taskspace {suite.HEADLINE_SEEDS}" in suite.OURS_RRT
    # the new-seed row: the first calls of the other seeds, solved
    fresh = per[suite.HEADLINE_NEW_SEED]
    assert fresh["ok"] == 1.0 and np.isfinite(fresh["time"]) and fresh["time"] > 0.0
    assert f"taskspace {suite.HEADLINE_NEW_SEED}" in suite.OURS_RRT
    assert suite.HEADLINE_NEW_SEED in suite.METHODS

    # The first plan's path is free for Pinocchio at the suite's resolution.
    res = calls[0][3]
    assert res.success
    assert first["length"] == pytest.approx(res.path_length, rel=1e-12)
    assert reference_free(robot, res.path, suite.RESOLUTION).all()


def test_scene_setup_is_kept_out_of_the_ratios(
    suite: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    def sample(time: float) -> dict[str, float]:
        return {"time": time, "ok": 1.0, "checks": 10.0, "length": 1.0, "short": np.nan}

    ours = {m: [sample(2e-4), sample(4e-4)] for m in suite.METHODS}
    ours["scene_setup"] = [
        {"time": t, "ok": 1.0, "checks": np.nan, "length": np.nan} for t in (1e-3, 3e-3)
    ]
    vamp_first = "vamp RRTConnect range=1 max_samples=1e5 (own spheres), wall first call"
    assert vamp_first in [label for _, _, label in suite.VAMP_ROWS]
    peers = {vamp_first: [sample(1e-4), sample(1e-4)]}
    monkeypatch.setattr(suite, "scenarios", lambda: ["s"])
    monkeypatch.setattr(suite, "_run_ours", lambda executor, scenario, quick: (ours, {}))
    monkeypatch.setattr(suite, "_run_peers", lambda scenario, quick: (peers, []))
    rows = {(row.scene, row.method): row for row in suite.run(quick=True)}

    setup = rows[("all", suite.SCENE_SETUP)]
    assert setup.ratio_to is None
    assert set(setup.extra) == {"valid", "median_ms", "p95_ms"}
    assert setup.extra["median_ms"] == pytest.approx(2.0)
    assert suite.SCENE_SETUP not in suite.OURS_RRT

    peer = rows[("all", vamp_first)].extra
    assert peer[f"ratio_median_{HEADLINE}_first_plan_over_peer"] == pytest.approx(3.0)
    assert not any("scene_setup" in key for key in peer)


def test_vamp_peer_reports_its_first_call(suite: ModuleType) -> None:
    from benchmarks.common import ROOT as CHECKOUT
    from benchmarks.common import peer_python

    exe = peer_python("vamp")
    if exe is None:
        pytest.skip("peer environment .venv-peers/vamp not installed")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["TASKSPACE_MOTIONBENCHMAKER_DIR"] = str(ROOT)
    cmd = [str(exe), str(CHECKOUT / "benchmarks/peers/vamp_planning.py"), "--problems", "2"]
    cmd += ["--scenarios", "table_pick", "--variants", suite.VAMP_VARIANTS, "--repeats", "2"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, check=True)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if "skipped" in out:
        pytest.skip(out["skipped"])
    for variant in suite.VAMP_VARIANTS.split(","):
        res = out["variants"][variant]["table_pick"]
        assert res["valid"] >= 1
        assert len(res["first_times"]) == len(res["times"]) == res["valid"]
        # the minimum over the repeats is at most the first of them
        assert all(m <= f for m, f in zip(res["times"], res["first_times"], strict=True))
