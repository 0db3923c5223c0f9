"""Robot motions of the examples written as pictures: a meshcat animation and a PNG snapshot."""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from taskspace._validation import as_float_array, check_int
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.viz.viewer import Viewer

logger = logging.getLogger(__name__)

SNAPSHOT_SIZE = (800, 600)
"""Pixel size of the robot pictures the examples write."""


def output_directory(save: str | Path | None) -> Path | None:
    """The directory of an example's ``--save`` value (a directory, or a ``.png`` file in it)."""
    if save is None:
        return None
    out = Path(save)
    return out.parent if out.suffix.lower() == ".png" else out


def save_robot_motion(
    viewer: Viewer,
    configurations: Any,
    save: str | Path | None,
    name: str,
    *,
    dt: float,
    title: str,
    picture: int = -1,
    snapshot: bool | None = None,
) -> list[Path]:
    """Write ``<save>/<name>.html`` (animation) and ``<save>/<name>_robot.png`` (snapshot).

    The viewer keeps what the example drew (obstacles, targets, paths); the PNG shows the robot
    at ``configurations[picture]`` (the last one by default) in headless Chromium, and the HTML
    is the whole motion as a meshcat animation with a time slider (:meth:`Viewer.play`).

    Args:
        viewer: the example's viewer, with the robot and its markers.
        configurations: ``(N, nq)`` configurations sampled every ``dt`` [s].
        save: the example's ``--save`` value (nothing is written when ``None``).
        name: file stem.
        dt: time between configurations [s].
        title: page title of the HTML.
        picture: index of the configuration shown in the PNG.
        snapshot: render the PNG (default: yes, unless ``TASKSPACE_SNAPSHOTS=0``); without a
            browser the PNG is skipped with a printed reason.

    Returns:
        The paths written (each is also printed).
    """
    out = output_directory(save)
    if out is None:
        return []
    qs = as_float_array(configurations, "configurations")  # complex, text: refused
    if qs.ndim != 2 or qs.shape[0] == 0:
        raise InvalidInputError(f"configurations must be (N, nq) with N >= 1, got {qs.shape}")
    index = check_int(picture, "picture")  # 2.5 was an IndexError, True the index 1
    if not -qs.shape[0] <= index < qs.shape[0]:
        raise InvalidInputError(f"picture index {picture} outside 0..{qs.shape[0] - 1}")
    if not isinstance(name, str) or not name or Path(name).name != name or name in (".", ".."):
        # "../../x" wrote outside the output directory
        raise InvalidInputError(f"name must be a file stem without directories, got {name!r}")
    for folder in (out, *out.parents):
        if folder.exists():
            if not folder.is_dir():
                raise InvalidInputError(f"save: {folder} is a file, not a directory")
            break
    if snapshot is None:
        snapshot = os.environ.get("TASKSPACE_SNAPSHOTS", "1") != "0"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if snapshot:
        from taskspace.viz.snapshots import SnapshotError

        png = out / f"{name}_robot.png"
        viewer.display(qs[index])
        print(f"rendering {png.name} in headless Chromium...", flush=True)
        try:
            viewer.snapshot(png, size=SNAPSHOT_SIZE)
            written.append(png)
        except SnapshotError as error:  # no browser here: say so, still write the animation
            print(f"no robot picture ({png.name}): {error}", flush=True)
    viewer.play(qs, dt=dt, autoplay=False)
    html = viewer.save_html(out / f"{name}.html", title=title)
    written.append(html)
    for path in written:
        print(f"wrote {path}", flush=True)
    return written
