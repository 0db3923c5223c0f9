"""The live viewer (URL, staying up until Ctrl-C, stopping its server) and figure pages."""

from __future__ import annotations

import _thread
import base64
import re
import threading
import urllib.request

import pytest

from taskspace.errors import InvalidInputError
from taskspace.viz import Viewer, figure_page_html, save_figure_page


@pytest.fixture
def live_viewer(robot_loader):
    viewer = Viewer(robot_loader("planar_2link"), live=True)
    yield viewer
    viewer.close()


def test_live_viewer_serves_its_url_until_the_timeout(live_viewer):
    url = live_viewer.url
    assert isinstance(url, str) and re.fullmatch(r"http://127\.0\.0\.1:\d+/static/", url)
    with urllib.request.urlopen(url, timeout=10) as page:  # the server answers
        assert page.status == 200
    server = live_viewer.recorder.forward.server_proc
    assert live_viewer.wait_until_interrupted(timeout=0.3) is False
    assert server.poll() is not None  # stopped
    assert not live_viewer.live
    with pytest.raises(InvalidInputError, match="not live"):
        live_viewer.url  # noqa: B018


def test_ctrl_c_ends_the_wait_cleanly(live_viewer):
    server = live_viewer.recorder.forward.server_proc
    timer = threading.Timer(0.3, _thread.interrupt_main)  # what Ctrl-C does
    timer.start()
    try:
        assert live_viewer.wait_until_interrupted(timeout=30) is True
    finally:
        timer.cancel()
    assert server.poll() is not None


def test_recorded_viewer_has_no_url():
    viewer = Viewer()
    with pytest.raises(InvalidInputError, match=r"Viewer\(\.\.\., live=True\)"):
        viewer.url  # noqa: B018
    with pytest.raises(InvalidInputError, match="not live"):
        viewer.wait_until_interrupted(timeout=0.1)


def test_figure_page_embeds_each_png(tmp_path):
    from PIL import Image

    files = []
    for i, color in enumerate(("red", "blue")):
        path = tmp_path / f"fig{i}.png"
        Image.new("RGB", (8, 6), color).save(path)
        files.append(path)
    out = save_figure_page(tmp_path / "sub" / "page.html", files, title="two <figures>")
    text = out.read_text(encoding="utf-8")
    assert "<title>two &lt;figures&gt;</title>" in text
    embedded = re.findall(r'src="data:image/png;base64,([^"]+)"', text)
    assert [base64.b64decode(e) for e in embedded] == [f.read_bytes() for f in files]
    assert "fig0.png" in text and "fig1.png" in text


def test_figure_page_errors(tmp_path):
    with pytest.raises(InvalidInputError, match="at least one PNG"):
        figure_page_html([])
    with pytest.raises(InvalidInputError, match="image not found"):
        figure_page_html([tmp_path / "missing.png"])
    (tmp_path / "a.txt").write_text("hello")
    with pytest.raises(InvalidInputError, match="not a PNG file"):
        figure_page_html([tmp_path / "a.txt"])
