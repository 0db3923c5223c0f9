"""A live meshcat server that dies or freezes gives LiveViewerError, not a hang (#15).

Before: the viewer's next command blocked for ever in meshcat's zmq recv. The commands run
in a worker thread joined with a timeout, so a regression fails instead of hanging the run.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import umsgpack

import taskspace.viz.viewer as viewer_module
from taskspace.errors import InvalidInputError
from taskspace.viz import LiveViewerError, Viewer

WAIT_S = 60.0  # far above the patched command timeout: only a hang reaches it


def _outcome(call: Callable[[], Any]) -> BaseException | None:
    box: list[BaseException | None] = []

    def run() -> None:
        try:
            call()
            box.append(None)
        except BaseException as exc:
            box.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(WAIT_S)
    assert box, f"the viewer command still blocks after {WAIT_S:g} s"
    return box[0]


@pytest.fixture
def live_viewer(robot_loader: Any, monkeypatch: pytest.MonkeyPatch) -> Any:
    monkeypatch.setattr(viewer_module, "LIVE_COMMAND_TIMEOUT_S", 1.0)
    viewer = Viewer(robot_loader("planar_2link"), live=True)
    yield viewer
    process = viewer.recorder.forward.server_proc if viewer.recorder.forward else None
    if process is not None and process.poll() is None:
        os.kill(process.pid, signal.SIGCONT)
    viewer.close()


def _check_recording_only(viewer: Any, why: str) -> None:
    assert not viewer.live
    with pytest.raises(InvalidInputError, match=why):
        viewer.url  # noqa: B018
    with pytest.raises(InvalidInputError, match=why):
        viewer.wait_until_interrupted(timeout=0.1)
    # later commands are recorded (not forwarded) and the scene exports
    assert _outcome(lambda: viewer.add_points("q", np.ones((2, 3)))) is None
    paths = {c["path"] for c in map(umsgpack.unpackb, viewer.recorder.packed_commands())}
    assert {"/meshcat/markers/p", "/meshcat/markers/q"} <= paths
    assert "<html" in viewer.static_html().lower()


def test_killed_server_raises_then_the_viewer_records_only(live_viewer: Any) -> None:
    process = live_viewer.recorder.forward.server_proc
    live_viewer.display(np.zeros(2))  # alive: fine
    assert live_viewer.live
    process.kill()  # killed from outside (the server this test started)
    process.wait(10)
    exc = _outcome(lambda: live_viewer.add_points("p", np.zeros((2, 3))))
    assert isinstance(exc, LiveViewerError) and "exited" in str(exc)
    _check_recording_only(live_viewer, "exited")


def test_frozen_server_raises_after_the_timeout(live_viewer: Any) -> None:
    process = live_viewer.recorder.forward.server_proc
    os.kill(process.pid, signal.SIGSTOP)  # alive but not answering
    try:
        exc = _outcome(lambda: live_viewer.add_points("p", np.zeros((2, 3))))
        assert isinstance(exc, LiveViewerError) and "did not answer within 1 s" in str(exc)
        _check_recording_only(live_viewer, "did not answer")
    finally:
        os.kill(process.pid, signal.SIGCONT)
