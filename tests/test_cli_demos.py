"""``taskspace demo`` and ``taskspace bench`` as a newcomer uses them.

Every demo accepts ``--html``, ``--png``, ``--save`` and ``--no-viewer``; output paths are
relative to the caller's directory (the commands run here from a temporary directory with
relative paths, and nothing may land in the repository). Demos run with ``TASKSPACE_FAST=1``.
Every demo prints the path of each file it writes; every demo that moves a robot writes its
motion into ``--save`` as ``<stem>.html`` (a meshcat animation) and ``<stem>_robot.png``.

:func:`test_every_demo_accepts_every_flag` is the test that runs every example of
``examples/``; the docs build of ``tests/test_docs.py`` runs only the three whose gallery
figures it checks.
"""

from __future__ import annotations

import ast
import base64
import itertools
import json
import os
import re
import subprocess
import sys
import zlib
from pathlib import Path

import pytest
import umsgpack
from PIL import Image

from taskspace.cli import (
    DEMO_FLAGS,
    benchmark_suites,
    demo_listing,
    discover_examples,
    main,
    native_flags,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(
    p
    for p in (ROOT / "examples").rglob("*.py")
    if not p.name.startswith("_") and "__pycache__" not in p.parts
)
TIMEOUT = 300  # seconds per demo run
ROBOT_EXAMPLES = {
    "demo_main",
    "cartpole_lqr",
    "g1_inverse_dynamics",
    "panda_computed_torque",
    "panda_operational_space",
    "panda_box_grasps",
    "allegro_hand_grasps",
    "g1_hands_hierarchy",
    "panda_reach_obstacle",
    "planar_3link_nullspace",
    "panda_dmp_obstacle",
    "g1_walking",
    "solo12_trot",
    "panda_shelf",
    "panda_path_optimization",
    "panda_pipeline",
}
"""Stems of the examples that move a robot model (their ``--save`` holds the motion)."""
OTHER_PICTURE_NAMES = {"g1_walking": "g1_walking_snapshot.png"}
"""Robot pictures not yet named ``<stem>_robot.png``."""
MOTIONBENCHMAKER = ROOT.parent / "shared" / "benchmarks" / "motionbenchmaker_panda"
"""The project's copy of the MotionBenchMaker problems (panda_shelf's Panda part needs it)."""


def _names() -> dict[Path, str]:
    examples = discover_examples()
    return {examples[name]: name for name, _ in demo_listing()}


def run_demo(cwd: Path, *args: str, fast: bool = True) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    if MOTIONBENCHMAKER.is_dir():
        env.setdefault("TASKSPACE_MOTIONBENCHMAKER_DIR", str(MOTIONBENCHMAKER))
    env.pop("DISPLAY", None)
    env.pop("MPLBACKEND", None)  # --no-viewer must select Agg itself
    if fast:
        env["TASKSPACE_FAST"] = "1"
    else:
        env.pop("TASKSPACE_FAST", None)
    proc = subprocess.run(
        [sys.executable, "-m", "taskspace.cli", "demo", *args],
        cwd=str(cwd),
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, (
        f"taskspace demo {' '.join(args)} exited with {proc.returncode}\n--- stdout ---\n"
        f"{proc.stdout[-3000:]}\n--- stderr ---\n{proc.stderr[-3000:]}"
    )
    return proc


def is_png(path: Path) -> bool:
    return path.is_file() and Image.open(path).format == "PNG"


def animation_commands(html: str) -> int:
    """How many ``set_animation`` commands a page of :meth:`Viewer.save_html` holds."""
    match = re.search(r"var TASKSPACE_SCENE = (\{.*?\});\n</script>", html, re.S)
    assert match is not None, "not a compressed meshcat page"
    scene = json.loads(match.group(1))
    data = zlib.decompress(base64.b64decode(scene["data"]))
    starts = [0]
    for size in scene["sizes"]:
        starts.append(starts[-1] + size)
    chunks = [data[a:b] for a, b in itertools.pairwise(starts)]
    commands = [umsgpack.unpackb(b"".join(chunks[i] for i in ids)) for ids in scene["commands"]]
    return sum(c["type"] == "set_animation" for c in commands)


def repo_outputs() -> set[Path]:
    """Files a misdirected demo would write into the checkout (its out/ folder)."""
    out = ROOT / "out"
    return set(out.rglob("*")) if out.is_dir() else set()


# ----------------------------------------------------------------------------- listing
def test_demo_list_shows_each_demo_once_with_its_description(capsys):
    assert main(["demo", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = [line.split()[0] for line in lines]
    assert len(names) == len(set(names)) == len(EXAMPLES)
    assert names[0] == "main" and "demo_main" not in names
    examples = discover_examples()
    assert sorted(examples[n] for n in names) == EXAMPLES  # every script, once
    for line, name in zip(lines, names):
        doc = ast.get_docstring(ast.parse(examples[name].read_text(encoding="utf-8"))) or ""
        first = " ".join(doc.split("\n\n")[0].split())
        assert line.split(maxsplit=1)[1] == first, name  # one line: the first paragraph


def test_every_listed_name_runs_that_script():
    examples = discover_examples()
    for name, _ in demo_listing():
        assert name in examples
    assert examples["main"].name == "demo_main.py"
    assert examples["planning/bug_paths"] == examples["bug_paths"]


def test_native_flags_read_from_the_scripts():
    examples = discover_examples()
    assert native_flags(examples["main"]) == set(DEMO_FLAGS)
    assert native_flags(examples["bug_paths"]) == {"--save"}
    assert native_flags(examples["g1_inverse_dynamics"]) == {"--save", "--html"}


def test_robot_examples_are_the_scripts_that_load_a_robot():
    loads = {
        p.stem
        for p in EXAMPLES
        if re.search(r"Robot\.load\(|motionbenchmaker_panda\(|Hand\.\w+\(", p.read_text("utf-8"))
    }
    assert loads == ROBOT_EXAMPLES


# ----------------------------------------------------------------------------- each flag
@pytest.mark.slow  # runs a demo in a subprocess (a few seconds)
def test_save_is_relative_to_the_caller(tmp_path):
    before = repo_outputs()
    proc = run_demo(tmp_path, "bug_paths", "--save", "figs")
    assert is_png(tmp_path / "figs" / "bug_paths.png")
    assert str(tmp_path / "figs" / "bug_paths.png") in proc.stdout  # says where it wrote
    assert repo_outputs() == before


@pytest.mark.slow  # runs a demo in a subprocess (a few seconds)
def test_png_alone_copies_the_picture(tmp_path):
    proc = run_demo(tmp_path, "wavefront_numbers", "--png", "pic/w.png")
    assert is_png(tmp_path / "pic" / "w.png")
    assert f"wrote {tmp_path / 'pic' / 'w.png'}" in proc.stdout
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == ["w.png"]


@pytest.mark.slow  # runs a demo in a subprocess (a few seconds)
def test_html_of_a_plot_demo_is_a_page_of_its_figures(tmp_path):
    proc = run_demo(tmp_path, "profile_comparison", "--html", "p.html")
    text = (tmp_path / "p.html").read_text(encoding="utf-8")
    assert text.count('src="data:image/png;base64,') >= 1
    assert f"wrote {tmp_path / 'p.html'}" in proc.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.html"]


@pytest.mark.slow  # runs a demo in a subprocess (a few seconds)
def test_no_viewer_keeps_the_main_demo_from_serving(tmp_path):
    # the full-length run (no TASKSPACE_FAST) would open the live viewer and wait for Ctrl-C
    proc = run_demo(tmp_path, "main", "--no-viewer", fast=False)
    assert "manipulability" in proc.stdout
    assert "meshcat viewer" not in proc.stdout and "127.0.0.1" not in proc.stdout
    assert not any(tmp_path.iterdir())


def test_unknown_demo_and_bad_flag_exit_2(capsys):
    assert main(["demo", "no_such_demo", "--png", "x.png"]) == 2
    assert "valid demos are:" in capsys.readouterr().err


# ----------------------------------------------------------------------------- every demo
@pytest.mark.slow
@pytest.mark.parametrize(
    "script", EXAMPLES, ids=[p.relative_to(ROOT / "examples").as_posix() for p in EXAMPLES]
)
def test_every_demo_accepts_every_flag(script, tmp_path):
    name = _names()[script]
    before = repo_outputs()
    args = ["--html", "out/a.html", "--png", "out/a.png", "--save", "all", "--no-viewer"]
    proc = run_demo(tmp_path, name, *args)
    assert is_png(tmp_path / "out" / "a.png"), proc.stdout[-2000:]
    html = (tmp_path / "out" / "a.html").read_text(encoding="utf-8")
    assert "MeshCat.Viewer" in html or "data:image/png;base64," in html
    saved = [p for p in (tmp_path / "all").rglob("*") if p.is_file()]
    assert saved, "nothing written into --save"
    unannounced = [p.name for p in saved if str(p) not in proc.stdout]
    assert not unannounced, f"written but not printed: {unannounced}"  # says what went where
    assert repo_outputs() == before
    stem = script.stem
    if stem not in ROBOT_EXAMPLES:
        return
    has_problems = MOTIONBENCHMAKER.is_dir() or "TASKSPACE_MOTIONBENCHMAKER_DIR" in os.environ
    if stem == "panda_shelf" and not has_problems:
        return  # its Panda part is skipped without the MotionBenchMaker problems
    page = (tmp_path / "all" / f"{stem}.html").read_text(encoding="utf-8")
    assert "MeshCat.Viewer" in page and animation_commands(page) == 1
    picture = tmp_path / "all" / OTHER_PICTURE_NAMES.get(stem, f"{stem}_robot.png")
    assert is_png(picture), f"no robot picture {picture.name}"


# ----------------------------------------------------------------------------- bench
def test_bench_help_lists_suites_and_compare(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["bench", "--help"])
    assert exit_info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--compare A B" in text
    suites = benchmark_suites()
    assert {"ik", "planning", "qp_backends"} <= set(suites)
    assert all(suite in text for suite in suites)
    assert suites == sorted(
        p.stem for p in (ROOT / "benchmarks" / "suites").glob("*.py") if p.stem[0] != "_"
    )


def test_bench_compare_relative_paths(tmp_path):
    def row(median):
        return {
            "suite": "ik",
            "scene": "panda",
            "method": "weighted",
            "timing": {"median_us": median},
        }

    (tmp_path / "a.json").write_text(json.dumps({"rows": [row(10.0)]}))
    (tmp_path / "b.json").write_text(json.dumps({"rows": [row(15.0)]}))
    proc = subprocess.run(
        [sys.executable, "-m", "taskspace.cli", "bench", "--compare", "a.json", "b.json"],
        cwd=str(tmp_path),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ik/panda/weighted" in proc.stdout and "1.50" in proc.stdout


def test_bench_unknown_suite_and_missing_file_exit_2(capsys, tmp_path):
    assert main(["bench", "no_such_suite"]) == 2
    err = capsys.readouterr().err
    assert "unknown suite(s) no_such_suite; valid suites are:" in err and "planning" in err
    assert main(["bench", "--compare", str(tmp_path / "x.json"), str(tmp_path / "y.json")]) == 2
    assert "no such results file" in capsys.readouterr().err
