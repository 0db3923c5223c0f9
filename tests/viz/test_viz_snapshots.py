"""Snapshot tests: meshcat scenes rendered by headless Chromium against reference PNGs.

References live in tests/snapshots/*.png and are rewritten only with UPDATE_SNAPSHOTS=1. On a
mismatch the actual image and a difference image are written to tests/snapshots/failures/.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest
from _viz_scenes import PANDA_IK_Q, SCENES, panda_default, panda_ik_target
from PIL import Image

from taskspace.errors import InvalidInputError
from taskspace.viz import compare_images, render_html
from taskspace.viz.image_comparison import ImageComparisonOptions
from taskspace.viz.snapshots import SnapshotError, SnapshotOptions, snapshot

SNAPSHOTS = Path(__file__).resolve().parents[1] / "snapshots"
FAILURES = SNAPSHOTS / "failures"
UPDATE = os.environ.get("UPDATE_SNAPSHOTS", "") not in ("", "0")
SIZE = (640, 480)

pytestmark = [pytest.mark.snapshot, pytest.mark.xdist_group("browser")]


def _render(viewer) -> bytes:  # type: ignore[no-untyped-def]
    return viewer.snapshot(size=SIZE)


def check_snapshot(name: str, png: bytes) -> None:
    reference = SNAPSHOTS / f"{name}.png"
    if UPDATE or not reference.is_file():
        if not UPDATE:
            pytest.fail(f"missing reference {reference}; run with UPDATE_SNAPSHOTS=1 to create it")
        SNAPSHOTS.mkdir(parents=True, exist_ok=True)
        reference.write_bytes(png)
        return
    result = compare_images(png, reference.read_bytes())
    if not result.success:
        FAILURES.mkdir(parents=True, exist_ok=True)
        (FAILURES / f"{name}_actual.png").write_bytes(png)
        if result.diff_png:
            (FAILURES / f"{name}_diff.png").write_bytes(result.diff_png)
        pytest.fail(
            f"snapshot '{name}' differs from {reference.name}: {result.summary()}; "
            f"actual and diff images in {FAILURES}"
        )


def _robot_pixels(png: bytes) -> int:
    """Pixels of the white/gray robot shell: bright and unsaturated (background is blue)."""
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    r, b = rgb[..., 0], rgb[..., 2]
    return int(((r > 180) & (np.abs(r - b) < 40)).sum())


@pytest.mark.parametrize("name", sorted(SCENES))
def test_snapshot_matches_reference(name, robot_loader):
    robot_name, build = SCENES[name]
    png = _render(build(robot_loader(robot_name)))
    assert Image.open(io.BytesIO(png)).size == SIZE
    assert _robot_pixels(png) > 1500, "no robot visible in the snapshot"
    check_snapshot(name, png)


def test_small_joint_change_fails_comparison(panda):
    reference = SNAPSHOTS / "panda_ik_target.png"
    if UPDATE or not reference.is_file():
        pytest.skip("reference being regenerated")
    q = PANDA_IK_Q.copy()
    q[0] += 0.01  # 0.01 rad on the first joint: the hand moves by about 5 mm
    png = _render(panda_ik_target(panda, q))
    result = compare_images(png, reference.read_bytes())
    assert not result.success, result.summary()
    assert result.differing_pixels > ImageComparisonOptions().max_differing_pixels


def test_static_html_renders_without_network(panda, tmp_path):
    viewer = panda_default(panda)
    html = viewer.static_html()
    assert "<script src" not in html and "MeshCat.Viewer" in html  # main.min.js inlined
    # A canary request proves that the routing really aborts network access.
    canary = '<img src="https://example.invalid/canary.png">'
    html = html.replace("<body>", "<body>" + canary, 1)
    path = tmp_path / "scene.html"
    path.write_text(html, encoding="utf-8")
    with pytest.raises(SnapshotError, match="JavaScript error") as info:
        render_html(path, SIZE, SnapshotOptions(offline=True))  # the blocked canary: an error
    assert info.value.page_errors and all("ERR_FAILED" in e for e in info.value.page_errors)
    allowed = SnapshotOptions(offline=True, allowed_page_errors=("ERR_FAILED",))
    result = render_html(path, SIZE, allowed)
    assert result.success, result
    assert result.blocked_requests == ["https://example.invalid/canary.png"]
    assert result.page_errors and all("ERR_FAILED" in e for e in result.page_errors)
    assert _robot_pixels(result.png) > 1500


def test_javascript_errors_fail_the_snapshot_unless_allowed(panda, tmp_path):
    """A page that throws is refused (render_html and snapshot), with the messages."""
    html = panda_default(panda).static_html()
    script = "<script>setTimeout(() => { throw new Error('taskspace-canary-42'); }, 0);</script>"
    path = tmp_path / "throws.html"
    path.write_text(html.replace("</body>", script + "</body>", 1), encoding="utf-8")
    with pytest.raises(SnapshotError, match="taskspace-canary-42") as info:
        render_html(path, SIZE)
    assert any("taskspace-canary-42" in e for e in info.value.page_errors)
    with pytest.raises(SnapshotError, match="taskspace-canary-42"):
        snapshot(path, size=SIZE)
    result = render_html(path, SIZE, SnapshotOptions(allowed_page_errors=("canary-42",)))
    assert result.success and any("taskspace-canary-42" in e for e in result.page_errors)
    with pytest.raises(InvalidInputError, match="allowed_page_errors"):
        SnapshotOptions(allowed_page_errors="canary")  # type: ignore[arg-type]


def test_animation_frame_matches_static_scene(robot_loader):
    """The exported animation, paused at its end, shows the last configuration."""
    from taskspace.viz import Viewer

    robot = robot_loader("planar_3link")
    q0 = np.array([0.3, 0.6, 0.4])
    q1 = np.array([1.2, -0.4, 0.9])
    camera = ([0.8, -1.8, 1.6], [0.8, 0.6, 0.0])

    animated = Viewer(robot, floor=False)
    animated.play(np.array([q0, q1]), dt=1.0, fps=20, autoplay=False)
    animated.set_camera(*camera)
    end = render_html(animated, SIZE, SnapshotOptions(animation_time=1.0))
    start = render_html(animated, SIZE, SnapshotOptions(animation_time=0.0))

    static = Viewer(robot, q1, floor=False)
    static.set_camera(*camera)
    reference = render_html(static, SIZE)
    assert end.success and start.success and reference.success
    assert compare_images(end.png, reference.png).success
    assert not compare_images(start.png, reference.png).success
