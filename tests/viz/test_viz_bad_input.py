"""The viewer on inputs it was not designed for (issue #15). No Chromium needed: every check
happens before a page is rendered.

Before: colors outside [0, 1] were clipped ((128, 128, 128) became white, -1 white, 0x1000000
black); ``play(fps=1e9)`` recorded frames for ever; ``repetitions='a'`` was a bare ValueError,
``2.7`` was truncated; ``static_html(title=None)`` a bare AttributeError; ``save_html`` into a
directory or an unwritable place a bare OSError, ``snapshot`` there failed only after
rendering; ``Viewer("panda")`` a bare AttributeError; ``Viewer(zmq_url=...)`` without a server
hung; float edges were truncated to other nodes; an arrow of length 1e300 had an infinite
shaft (float32); ``delete("tcp")`` also forgot the bounds of "tcp2" and of "tcp_nodes"; and
after ``close()`` the viewer said it had never been live.
"""

from __future__ import annotations

import io
import socket
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.viz import Viewer
from taskspace.viz import viewer as viewer_module
from taskspace.viz.meshcat_geometry import parse_color
from taskspace.viz.snapshots import SnapshotOptions


@pytest.fixture(scope="module")
def viewer(robot_loader):  # type: ignore[no-untyped-def]
    """A viewer of a robot made of primitives (exports in milliseconds, not seconds)."""
    return Viewer(robot_loader("planar_2link"))


@pytest.mark.parametrize(
    ("color", "match"),
    [
        ((255, 0, 0), "divide by 255"),
        ((128, 128, 128), "in \\[0, 1\\]"),
        ((1.0, 0.0, 0.0, 2.0), "in \\[0, 1\\]"),
        ((-0.5, 0.0, 0.0), "in \\[0, 1\\]"),
        (-1, "0xRRGGBB"),
        (0x1000000, "0xRRGGBB"),
    ],
)
def test_colors_out_of_range_are_refused(color, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match=match):
        parse_color(color)


def test_colors_in_range_are_exact() -> None:
    np.testing.assert_array_equal(parse_color(0xFF8000), [1.0, 128 / 255, 0.0, 1.0])
    np.testing.assert_array_equal(parse_color((0.2, 0.4, 0.6)), [0.2, 0.4, 0.6, 1.0])
    np.testing.assert_array_equal(parse_color((0, 0, 0, 0)), [0.0, 0.0, 0.0, 0.0])
    # a rounding overshoot of 1e-12 is clipped, not refused
    np.testing.assert_array_equal(parse_color((1 + 1e-12, 0, 0)), [1.0, 0.0, 0.0, 1.0])


def test_viewer_color_override_is_checked(robot_loader) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="divide by 255"):
        Viewer(robot_loader("planar_2link"), color=(200, 30, 30))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(dt=0.1, fps=1e9), "animation frames"),
        (dict(dt=1e9), "animation frames"),
        (dict(dt=0.1, repetitions="a"), "repetitions must be an integer"),
        (dict(dt=0.1, repetitions=2.7), "repetitions must be an integer"),
        (dict(dt=0.1, repetitions=0), "repetitions must be an integer >= 1"),
        (dict(dt=0.1, autoplay="no"), "autoplay must be True or False"),
    ],
)
def test_play_arguments(viewer, kwargs, match) -> None:  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    with pytest.raises(InvalidInputError, match=match):
        viewer.play(np.zeros((3, 2)), **kwargs)
    assert time.perf_counter() - start < 5.0  # refused up front, not after recording frames


def test_play_still_records_the_expected_frames(viewer) -> None:  # type: ignore[no-untyped-def]
    # 3 configurations 0.5 s apart at 10 fps: 1 s -> frames at 0, 0.1, ..., 1.0 s
    assert viewer.play(np.zeros((3, 2)), dt=0.5, fps=10.0, repetitions=2) == 11


def test_title_must_be_text(viewer) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="title must be a string"):
        viewer.static_html(title=None)
    page = viewer.static_html(title="<b>x</b>")
    assert "<title>&lt;b&gt;x&lt;/b&gt;</title>" in page


def test_output_paths(viewer, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="is a directory"):
        viewer.save_html(tmp_path)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InvalidInputError, match="is a file"):
        viewer.save_html(blocker / "scene.html")
    with pytest.raises(InvalidInputError, match="path must be a file name"):
        viewer.save_html(None)
    # refused before Chromium starts (this test does not need a browser)
    start = time.perf_counter()
    with pytest.raises(InvalidInputError, match="is a directory"):
        viewer.snapshot(tmp_path)
    with pytest.raises(InvalidInputError, match="is a file"):
        viewer.snapshot(blocker / "x.png")
    assert time.perf_counter() - start < 2.0
    out = viewer.save_html(tmp_path / "a" / "b" / "scene.html")
    assert out.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")


def test_unwritable_path_is_a_taskspace_error(viewer, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    missing = tmp_path / "x"
    # /proc refuses new files even for root
    with pytest.raises(InvalidInputError, match="cannot write"):
        viewer.save_html(Path("/proc") / f"taskspace-test-{missing.name}.html")


def test_robot_must_be_a_robot() -> None:
    with pytest.raises(InvalidInputError, match="taskspace Robot"):
        Viewer("panda")  # type: ignore[arg-type]


def test_no_meshcat_server_does_not_hang(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(viewer_module, "ZMQ_CONNECT_TIMEOUT_S", 0.3)
    with socket.socket() as s:  # a free port: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    start = time.perf_counter()
    with pytest.raises(InvalidInputError, match="no meshcat server answered"):
        Viewer(zmq_url=f"tcp://127.0.0.1:{port}")
    assert time.perf_counter() - start < 5.0
    with pytest.raises(InvalidInputError, match="not a valid zmq address"):
        Viewer(zmq_url="nonsense")


def test_float_edges_are_not_truncated(viewer) -> None:  # type: ignore[no-untyped-def]
    nodes = np.eye(3)
    with pytest.raises(InvalidInputError, match="integer node indices"):
        viewer.add_tree("t", nodes, [[0.5, 1.7]])
    viewer.add_tree("t", nodes, [[0.0, 1.0]])  # integral floats are fine
    viewer.add_tree("t", nodes, np.array([[0, 2]], dtype=np.int32))


@pytest.mark.parametrize(
    ("draw", "match"),
    [
        (lambda v: v.add_arrow("a", [0, 0, 0], [1e300, 0, 1]), "arrow"),
        (lambda v: v.add_frame("f", [1e35, 0, 0]), "frame"),
        (lambda v: v.add_frame("f", [0, 0, 0], scale=1e300), "frame"),
        (lambda v: v.add_points("p", [[0, 0, 1e300]]), "points"),
        (lambda v: v.add_path("p", [[0, 0, 0], [0, 0, 1]], radius=1e300), "path"),
        (lambda v: v.add_segments("s", [[[0, 0, 0], [1e31, 0, 0]]]), "segments"),
        (lambda v: v.add_com("c", radius=1e40), "radius"),
        (lambda v: v.set_camera([1e300, 0, 0]), "camera"),
    ],
)
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_coordinates_beyond_float32_are_refused(viewer, draw, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match=f"{match}.*float32"):
        draw(viewer)


def test_delete_forgets_only_that_marker(robot_loader) -> None:  # type: ignore[no-untyped-def]
    viewer = Viewer(robot_loader("planar_2link"), floor=False)
    viewer.add_frame("tcp", [0, 0, 0])
    viewer.add_frame("tcp2", [5, 0, 0])
    viewer.add_tree("tcp_tree", np.array([[0, 0, 0], [0, 7, 0]]), [[0, 1]], node_size=0.01)
    viewer.delete("tcp")
    hi = viewer.scene_bounds()[1]
    # tcp2 (x = 5 + its 0.1 m triad) and tcp_tree's nodes (y = 7) are still drawn and framed
    assert hi[0] == pytest.approx(5.1) and hi[1] == pytest.approx(7.0)
    viewer.delete("tcp_tree")
    assert viewer.scene_bounds()[1][1] == pytest.approx(7.0)  # tcp_tree_nodes stays
    viewer.delete("tcp_tree_nodes")
    assert viewer.scene_bounds()[1][1] < 7.0


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(timeout=float("nan")),
        dict(timeout=float("inf")),
        dict(timeout=-1.0),
        dict(timeout=1e6),
        dict(poll_interval=-0.05),
        dict(poll_interval=0.0),
        dict(stable_captures=0),
        dict(stable_captures=2.5),
        dict(offline="yes"),
        dict(animation_time=float("nan")),
        dict(animation_time=-1.0),
    ],
)
def test_snapshot_options(kwargs) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError):
        SnapshotOptions(**kwargs)


def test_a_closed_viewer_says_so_and_keeps_its_scene(robot_loader, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    viewer = Viewer(robot_loader("planar_2link"), live=True)
    viewer.close()
    viewer.close()  # twice is fine
    with pytest.raises(InvalidInputError, match="close\\(\\) stopped its meshcat server"):
        viewer.url  # noqa: B018
    with pytest.raises(InvalidInputError, match="not live any more"):
        viewer.open()
    viewer.display(np.array([0.3, -0.2]))  # recorded, not sent
    viewer.add_frame("f", [0.0, 0.0, 0.5])
    assert viewer.save_html(tmp_path / "after_close.html").stat().st_size > 1000


@pytest.mark.slow
@pytest.mark.snapshot
@pytest.mark.xdist_group("browser")
def test_snapshots_from_threads_and_after_ctrl_c(robot_loader) -> None:  # type: ignore[no-untyped-def]
    """Before: the browser belonged to the first snapshot's thread; any other thread got
    "Cannot switch to a different thread", and once that thread ended no snapshot worked."""
    import os
    import signal
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from PIL import Image

    robot = robot_loader("planar_2link")

    def shot(i: int) -> bytes:
        return Viewer(robot, q=np.array([0.4 * i, 0.2]), floor=False).snapshot(size=(64, 48))

    with ThreadPoolExecutor(2) as pool:
        pngs = list(pool.map(shot, range(3)))
    pngs.append(shot(0))  # the main thread, after the pool's threads have ended
    for png in pngs:
        assert Image.open(io.BytesIO(png)).size == (64, 48)
    assert pngs[0] == pngs[3] and pngs[0] != pngs[1]  # the same scene, the same image
    if threading.current_thread() is threading.main_thread():
        # a real SIGINT (Ctrl-C) during a snapshot stops the wait; the browser stays usable
        timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
        timer.start()
        try:
            with pytest.raises(KeyboardInterrupt):
                for _ in range(50):  # one of them is interrupted
                    shot(1)
        finally:
            timer.cancel()
        assert shot(0) == pngs[0]


def test_save_robot_motion_arguments(viewer, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from taskspace.viz.motion import save_robot_motion

    qs = np.zeros((3, 2))

    def save(**kw: Any) -> list[Path]:
        args: dict[str, Any] = dict(
            configurations=qs, save=tmp_path, name="m", dt=0.1, title="t", snapshot=False
        )
        args.update(kw)
        return save_robot_motion(viewer, **args)

    cases: list[tuple[dict[str, Any], str]] = [
        (dict(picture=2.5), "picture must be an integer"),  # was an IndexError with a snapshot
        (dict(picture=True), "picture must be an integer"),  # was the index 1
        (dict(picture="0"), "picture must be"),  # was a bare TypeError
        (dict(configurations=qs + 1j), "complex"),  # imaginary part was dropped
        (dict(configurations="ab"), "text"),  # bare ValueError
        (dict(name="../../x"), "file stem"),  # wrote outside the output directory
        (dict(save=tmp_path / "m.html" / "sub"), "m.html is a file"),
    ]
    for kw, match in cases:
        (tmp_path / "m.html").write_text("x")
        with pytest.raises(InvalidInputError, match=match):
            save(**kw)
    (tmp_path / "m.html").unlink()
    assert [p.name for p in save(picture=np.int64(-1))] == ["m.html"]


def test_figure_page_arguments(tmp_path: Path) -> None:
    from taskspace.viz import figure_page_html, save_figure_page

    with pytest.raises(InvalidInputError, match="one path"):
        figure_page_html(str(tmp_path / "a.png"))  # was read letter by letter: "not found: /"
    with pytest.raises(InvalidInputError, match="title must be a string"):
        figure_page_html([tmp_path / "a.png"], title=None)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="is a directory"):
        save_figure_page(tmp_path, [tmp_path / "a.png"])
