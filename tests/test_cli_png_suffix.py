"""PNG outputs refuse other image suffixes (#15): ``snapshot --png x.jpg`` wrote PNG bytes
into a .jpg file. Refused (not converted), before loading or rendering anything."""

from __future__ import annotations

from pathlib import Path

import pytest

from taskspace.cli import main
from taskspace.errors import InvalidInputError


@pytest.mark.parametrize("name", ["x.jpg", "x.JPEG", "x.webp", "x.png.gif", "x.html"])
def test_cli_snapshot_png_with_another_suffix(capsys, tmp_path: Path, name: str) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / name
    assert main(["snapshot", "panda", "--png", str(out)]) == 2
    err = capsys.readouterr().err
    assert "PNG" in err and ".png" in err and "Traceback" not in err
    assert not out.exists()


def test_cli_demo_png_with_another_suffix(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "demo.jpg"
    assert main(["demo", "main", "--png", str(out), "--no-viewer"]) == 2
    assert "PNG" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("name", ["x.jpg", "x.JPG", "dir/y.bmp"])
def test_api_snapshot_path_with_another_suffix(tmp_path: Path, name: str) -> None:
    from taskspace.viz import Viewer, snapshot

    viewer = Viewer()
    with pytest.raises(InvalidInputError, match=r"PNG data; name the file .*\.png"):
        viewer.snapshot(tmp_path / name)
    with pytest.raises(InvalidInputError, match="PNG data"):
        snapshot("<html></html>", tmp_path / name)
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize("name", ["x.png", "X.PNG", "no_suffix"])
def test_png_names_are_accepted(tmp_path: Path, name: str) -> None:
    from taskspace.viz.snapshots import check_png_path

    assert check_png_path(tmp_path / name) == tmp_path / name
