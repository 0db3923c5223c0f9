"""The ``taskspace`` command on bad arguments and Ctrl-C (issue #15).

Before: ``snapshot --png DIR`` (or ``--html DIR``, or a path under a file) printed a bare
IsADirectoryError / FileNotFoundError traceback, after loading the robot and rendering for
seconds; ``bench --compare`` of a file that is not a saved run printed the runner's
JSONDecodeError / KeyError / TypeError traceback; Ctrl-C printed a KeyboardInterrupt
traceback (``snapshot``, ``robots``) and exited with -2 (killed by SIGINT), and ``demo`` /
``bench`` exited 130 but their child printed its own traceback.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import taskspace.cli as cli
from taskspace.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("flag", ["--png", "--html"])
def test_snapshot_output_is_a_directory(capsys, tmp_path, flag) -> None:  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    assert main(["snapshot", "panda", flag, str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{flag} {tmp_path}: is a directory" in err and "Traceback" not in err
    assert time.perf_counter() - start < 2.0  # refused before loading and rendering


def test_snapshot_output_under_a_file(capsys, tmp_path) -> None:  # type: ignore[no-untyped-def]
    (tmp_path / "f").write_text("x")
    assert main(["snapshot", "panda", "--png", str(tmp_path / "f" / "x.png")]) == 2
    assert "is a file, not a directory" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{bad", "is not a JSON file of saved results"),
        ("{}", "is not a run saved by `taskspace bench --save`"),
        ("[]", "is not a run saved by"),
        ('{"rows": [{"suite": "ik"}]}', "suite, scene, method, timing"),
        (b"\xff\xfe", "is not a JSON file"),
    ],
)
def test_bench_compare_of_a_file_that_is_not_a_run(capsys, tmp_path, content, match) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.json"
    if isinstance(content, bytes):
        bad.write_bytes(content)
    else:
        bad.write_text(content)
    assert main(["bench", "--compare", str(bad), str(bad)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err


def test_bench_and_demo_outputs_that_cannot_be_written(capsys, tmp_path) -> None:  # type: ignore[no-untyped-def]
    blocker = tmp_path / "file"
    blocker.write_text("x")
    # an unknown suite: a regression fails at once instead of running a benchmark
    assert main(["bench", "no_such_suite", "--save", str(blocker / "r.json")]) == 2
    assert "is a file, not a directory" in capsys.readouterr().err
    assert main(["demo", "main", "--save", str(blocker)]) == 2
    assert "is a file; give a directory" in capsys.readouterr().err
    assert main(["demo", "main", "--png", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_an_os_error_is_a_message_not_a_traceback(capsys, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    def fail(args):  # type: ignore[no-untyped-def]
        raise PermissionError(13, "Permission denied", "/root/x.png")

    monkeypatch.setattr(cli, "cmd_snapshot", fail)
    assert main(["snapshot", "panda", "--png", "x.png"]) == 1
    assert "taskspace snapshot: error: [Errno 13] Permission denied: '/root/x.png'" in (
        capsys.readouterr().err
    )


def test_ctrl_c_in_process_exits_130(capsys, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    def interrupted(args):  # type: ignore[no-untyped-def]
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "cmd_robots", interrupted)
    assert main(["robots"]) == 130
    assert capsys.readouterr().err.strip() == "taskspace robots: interrupted"


def _interrupt(command: list[str], ready: str, env: dict[str, str] | None = None):  # type: ignore[no-untyped-def]
    """Start ``command`` in its own process group, wait for ``ready`` on stdout, Ctrl-C it."""
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=str(ROOT),
        env=env,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 60
        seen = ""
        while ready not in seen and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            seen += line
        assert ready in seen, seen
        time.sleep(0.3)
        os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole group
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return proc.returncode, seen + out, err


def test_ctrl_c_of_a_demo_stops_its_child_cleanly(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The child gets the SIGINT too: it runs its cleanup, prints no traceback, exits 130."""
    script = tmp_path / "sleeper.py"
    marker = tmp_path / "cleaned"
    script.write_text(
        textwrap.dedent(
            f"""
            import time
            print("ready", flush=True)
            try:
                time.sleep(60)
            finally:
                open({str(marker)!r}, "w").close()
            """
        )
    )
    code = textwrap.dedent(
        f"""
        import sys
        from pathlib import Path
        import taskspace.cli as cli
        cli.discover_examples = lambda root=None: {{"sleeper": Path({str(script)!r})}}
        sys.exit(cli.main(["demo", "sleeper", "--no-viewer"]))
        """
    )
    rc, _out, err = _interrupt([sys.executable, "-c", code], "ready")
    assert rc == 130, err
    assert "Traceback" not in err, err
    assert "taskspace demo: interrupted" in err
    assert marker.exists()  # the child's finally ran


@pytest.mark.slow
def test_ctrl_c_of_a_snapshot_exits_130_without_traceback(tmp_path) -> None:  # type: ignore[no-untyped-def]
    rc, _out, err = _interrupt(
        [
            sys.executable,
            "-m",
            "taskspace.cli",
            "snapshot",
            "talos",
            "--png",
            str(tmp_path / "x.png"),
        ],
        "rendering the PNG snapshot",
    )
    assert rc == 130, err
    assert "Traceback" not in err and "Future exception" not in err, err
    assert err.strip().endswith("taskspace snapshot: interrupted")
    assert not (tmp_path / "x.png").exists()


def test_children_run_as_python_runs_them(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The bootstrap of demo/bench children keeps __main__, sys.argv, sys.path[0], exit codes."""
    (tmp_path / "helper_mod.py").write_text("VALUE = 42\n")
    script = tmp_path / "show.py"
    script.write_text(
        textwrap.dedent(
            """
            import sys, helper_mod
            print(__name__, __file__, sys.argv[1:], sys.path[0], helper_mod.VALUE)
            sys.exit(int(sys.argv[1]))
            """
        )
    )
    boot = [sys.executable, "-c", cli._QUIET_INTERRUPT]
    direct = subprocess.run(
        [sys.executable, str(script), "3", "x"], capture_output=True, text=True, cwd=ROOT
    )
    booted = subprocess.run(
        [*boot, str(script), "3", "x"], capture_output=True, text=True, cwd=ROOT
    )
    assert booted.returncode == direct.returncode == 3
    assert booted.stdout == direct.stdout
    assert booted.stdout.split()[:2] == ["__main__", str(script)]
    failing = subprocess.run(
        [*boot, "-m", "json.tool", str(tmp_path / "missing.json")], capture_output=True, text=True
    )
    assert failing.returncode != 0 and "missing.json" in failing.stderr
