"""The ``taskspace`` command line: output of each command and clear errors on bad arguments."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from taskspace.cli import discover_examples, main, parse_configuration
from taskspace.errors import TaskspaceError

ROOT = Path(__file__).resolve().parents[1]


def test_robots_table(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    lines = {line.split()[0]: line.split() for line in out.splitlines()[2:]}
    # Panda: 7 revolute joints once the fingers are locked; fixed base.
    assert lines["panda"][1:4] == ["7", "7", "no"]
    assert "panda_hand_tcp" in lines["panda"]
    # floating base: nq = nv + 1 (quaternion)
    assert lines["talos"][3] == "yes" and int(lines["talos"][1]) == int(lines["talos"][2]) + 1
    assert lines["planar_2link"][1:4] == ["2", "2", "no"]


def test_unknown_robot_lists_valid_names(capsys, tmp_path):
    assert main(["snapshot", "pandaa", "--png", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "unknown robot 'pandaa'" in err and "panda" in err and "talos" in err


@pytest.mark.parametrize(
    ("q", "message"),
    [
        ("0,0,abc,0,0,0,0", "'abc' is not a number"),
        ("0,0,0", "--q has 3 values but the robot has nq = 7"),
        ("", "--q has 0 values"),
    ],
)
def test_malformed_configuration(capsys, tmp_path, q, message):
    assert main(["snapshot", "panda", "--q", q, "--png", str(tmp_path / "x.png")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_parse_configuration_accepts_commas_and_spaces():
    assert parse_configuration("0, 0.5 -1e-1,2", 4) == [0.0, 0.5, -0.1, 2.0]
    with pytest.raises(TaskspaceError, match="nq = 2"):
        parse_configuration("1 2 3", 2)


def test_demo_discovery_and_unknown_demo(capsys):
    examples = discover_examples()
    assert examples["main"].name == "demo_main.py"
    assert main(["demo", "list"]) == 0
    assert "main" in capsys.readouterr().out.split()
    assert main(["demo", "no_such_demo"]) == 2
    err = capsys.readouterr().err
    assert "unknown demo 'no_such_demo'; valid demos are:" in err and "main" in err


def test_bench_unknown_suite_fails():
    proc = subprocess.run(
        [sys.executable, "-m", "taskspace.cli", "bench", "no_such_suite", "--quick"],
        cwd=str(ROOT),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode != 0
    assert "no_such_suite" in proc.stderr


def test_bad_subcommand_exits_2():
    proc = subprocess.run(
        [sys.executable, "-m", "taskspace.cli", "fly"], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2 and "invalid choice: 'fly'" in proc.stderr


@pytest.mark.snapshot
@pytest.mark.xdist_group("browser")
def test_snapshot_command_writes_png_and_html(tmp_path, capsys):
    png = tmp_path / "panda.png"
    html = tmp_path / "panda.html"
    q = "0.2,-0.5,0,-2.2,0,1.8,0.8"
    argv = ["snapshot", "panda", "--q", q, "--png", str(png), "--html", str(html)]
    assert main([*argv, "--width", "320", "--height", "240"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {png}" in out and f"wrote {html}" in out
    assert Image.open(io.BytesIO(png.read_bytes())).size == (320, 240)
    assert "MeshCat.Viewer" in html.read_text()


@pytest.mark.snapshot
@pytest.mark.xdist_group("browser")
def test_demo_main_writes_outputs(tmp_path):
    env_cmd = [sys.executable, "-m", "taskspace.cli", "demo", "main"]
    proc = subprocess.run(
        [*env_cmd, "--html", str(tmp_path / "d.html"), "--png", str(tmp_path / "d.png")],
        cwd=str(ROOT),
        capture_output=True,
        text=True,
        timeout=300,
        env={**__import__("os").environ, "TASKSPACE_FAST": "1"},
    )
    assert proc.returncode == 0, proc.stderr
    assert "manipulability sqrt(det(J J^T)) = " in proc.stdout
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_info_reports_versions_and_kernels(capsys, monkeypatch):
    import re

    import pinocchio as pin

    from taskspace import _native

    assert main(["info"]) == 0
    lines = dict(
        re.split(r"\s{2,}", line, maxsplit=1)
        for line in capsys.readouterr().out.split("\n")
        if re.search(r"\S\s{2,}\S", line)
    )
    assert lines["pinocchio"] == pin.__version__
    ik = lines["IK kernel (weighted and hierarchical differential IK)"]
    assert ik == ("compiled, in use" if _native.ik_kernel() is not None else "not in use")
    idqp = lines["inverse-dynamics kernel (weighted ID-QP step)"]
    assert idqp == ("compiled, in use" if _native.idqp_kernel() is not None else "not in use")
    # without the kernels: said so, with the reason
    monkeypatch.setattr(_native, "ik_kernel", lambda: None)
    monkeypatch.setattr(_native, "idqp_kernel", lambda: None)
    monkeypatch.setattr(_native, "planning_kernel", lambda: None)
    monkeypatch.setattr(_native, "status", lambda: "not built (test)")
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert out.count("not in use") == 3 and "not built (test)" in out
