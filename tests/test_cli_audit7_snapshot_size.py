"""``taskspace snapshot`` checks the PNG size before it loads the robot and writes the HTML.

Before, ``--width 0`` (or 100000) loaded the robot, wrote the ``--html`` file, printed
"rendering..." and only then failed with exit status 1; it is a usage error (status 2) now,
with nothing written.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from taskspace import cli


@pytest.mark.parametrize(("width", "height"), [(0, 480), (-5, 480), (100000, 1), (640, 15)])
def test_bad_png_size_is_a_usage_error_before_any_work(
    width: int,
    height: int,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def no_load(*args: object, **kwargs: object) -> None:
        raise AssertionError("the robot was loaded before the size was checked")

    from taskspace.model import Robot

    monkeypatch.setattr(Robot, "load", no_load)
    html = tmp_path / "x.html"
    argv = ["snapshot", "panda", "--png", str(tmp_path / "x.png"), "--html", str(html)]
    status = cli.main([*argv, "--width", str(width), "--height", str(height)])
    err = capsys.readouterr().err
    assert status == 2
    assert "--width and --height must be within 16..4096 pixels each" in err
    assert f"--width {width} --height {height}" in err
    assert not html.exists() and not (tmp_path / "x.png").exists()


def test_html_alone_ignores_the_png_size(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    loaded: list[str] = []

    def stop(name: str, **kwargs: object) -> None:
        loaded.append(name)
        raise KeyboardInterrupt  # past the checks: the command starts its work

    from taskspace.model import Robot

    monkeypatch.setattr(Robot, "load", stop)
    status = cli.main(["snapshot", "panda", "--html", str(tmp_path / "x.html"), "--width", "0"])
    assert status == 130 and loaded == ["panda"]
