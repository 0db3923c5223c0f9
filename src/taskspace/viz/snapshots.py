"""PNG snapshots of meshcat scenes rendered by headless Chromium through Playwright.

The static HTML of a scene (:meth:`taskspace.viz.Viewer.static_html`) is loaded from a
``file://`` URL in Debian's Chromium (``/usr/bin/chromium``, software WebGL through
SwiftShader). The renderer waits for

1. the readiness token: the last scene command sets the property ``taskspace_ready_token`` of
   the node ``/taskspace_ready`` (polled through ``viewer.scene_tree``), so every command was
   applied, and no texture image is still loading (the page counts them);
2. a still scene: with meshcat's control panel (dat.gui) hidden by injected CSS, consecutive
   screenshots of the page (the WebGL canvas) are identical; the last one is returned.

One browser is started per process and reused (about 1 s to start, then each snapshot costs
the page load). Playwright's synchronous API only works on the thread that started it, so the
browser lives on one thread of its own and every snapshot, from any thread, runs there (one at
a time). Ctrl-C in the caller stops the wait at once; the page being rendered is abandoned at
its next poll and the browser stays usable.

Thread safety: snapshots may be requested from any thread: they run one at a time on the browser
thread (above). :class:`SnapshotOptions` and :class:`SnapshotResult` are immutable values (do not
modify the result's lists); :class:`SnapshotError` is an exception.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import logging
import queue
import shutil
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from taskspace._validation import check_count, check_int, check_positive
from taskspace.errors import InvalidInputError, TaskspaceError

logger = logging.getLogger(__name__)

CHROMIUM_PATH = "/usr/bin/chromium"
"""Browser used for snapshots (Debian's ``chromium`` package, never a downloaded browser)."""

CHROMIUM_ARGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--force-device-scale-factor=1",
    "--hide-scrollbars",
    "--disable-dev-shm-usage",
)

HIDE_CONTROLS_CSS = ".dg, .dg.ac, .dg.main { display: none !important; }"
"""CSS injected before the screenshot: hides meshcat's dat.gui control panel."""

_READY_JS = """() => {
  try {
    if (typeof viewer === "undefined") { return null; }
    if ((window.__taskspace_pending_images || 0) > 0) { return null; }
    const node = viewer.scene_tree.find(["taskspace_ready"]);
    return node.object.taskspace_ready_token || null;
  } catch (e) { return null; }
}"""

_PAUSE_JS = """(t) => {
  try {
    const a = viewer.animator;
    if (a && a.actions && a.actions.length) {
      // actions only apply once started: start them, stop the clock, then seek
      a.play(); a.pause(); a.seek(t); viewer.set_dirty(); return true;
    }
  } catch (e) { return false; }
  return false;
}"""


class SnapshotError(TaskspaceError):
    """The browser could not start, the scene did not settle in time, or the page had errors.

    Attributes:
        page_errors: the page's JavaScript errors that no allow-list entry matched (empty
            for the other causes).
    """

    def __init__(self, message: str, page_errors: Sequence[str] = ()) -> None:
        super().__init__(message)
        self.page_errors = list(page_errors)


@dataclass(frozen=True, kw_only=True)
class SnapshotOptions:
    """Settings of :func:`render_html`.

    Attributes:
        timeout: maximum time for loading and settling the scene [s].
        poll_interval: time between readiness polls and canvas captures [s].
        stable_captures: number of consecutive identical screenshots required.
        offline: abort every request that is not ``file:`` or ``data:`` (the static HTML must
            not need the network).
        animation_time: pause a meshcat animation at this time [s] before the screenshot
            (``None`` leaves it playing, and the scene never becomes still).
        allowed_page_errors: fragments of JavaScript error messages that are known to be
            harmless: a page error containing one of them is kept in
            :attr:`SnapshotResult.page_errors` without failing the snapshot. Any other page
            error makes :func:`render_html` raise :class:`SnapshotError` (a page with errors
            may show a scene that is wrong or incomplete).
    """

    timeout: float = 60.0
    poll_interval: float = 0.05
    stable_captures: int = 2
    offline: bool = True
    animation_time: float | None = 0.0
    allowed_page_errors: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        allowed = self.allowed_page_errors
        if not isinstance(allowed, tuple) or not all(isinstance(a, str) and a for a in allowed):
            raise InvalidInputError(
                "allowed_page_errors must be a tuple of non-empty message fragments (str), "
                f"got {allowed!r}"
            )
        # NaN timeouts failed at once, inf ones made playwright raise, negative polls a bare
        # playwright error; a snapshot needs a finite wait
        check_positive(self.timeout, "timeout")
        if self.timeout > 3600.0:
            raise InvalidInputError(f"timeout must be at most 3600 s, got {self.timeout!r}")
        check_positive(self.poll_interval, "poll_interval")
        check_count(self.stable_captures, "stable_captures", minimum=1)
        if not isinstance(self.offline, (bool, np.bool_)):
            raise InvalidInputError(f"offline must be True or False, got {self.offline!r}")
        if self.animation_time is not None:
            check_positive(self.animation_time, "animation_time", strict=False)


@dataclass(frozen=True, kw_only=True)
class SnapshotResult:
    """Result of :func:`render_html`.

    Attributes:
        png: the screenshot (PNG bytes).
        success: whether the token was seen and the scene became still.
        token: the readiness token read from the page (``None`` if never seen).
        captures: number of screenshots taken until the scene was still.
        blocked_requests: URLs aborted by the offline routing.
        page_errors: JavaScript errors (uncaught, console errors, failed commands) that
            ``SnapshotOptions.allowed_page_errors`` allowed (any other one raises).
        seconds: wall time of the rendering [s].
    """

    png: bytes
    success: bool
    token: str | None
    captures: int
    blocked_requests: list[str] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    seconds: float = 0.0


class BrowserSession:
    """One headless Chromium (persistent context in a fresh temporary profile), reused.

    Use :func:`browser_session` to get the process-wide instance; it is closed at exit.
    """

    def __init__(self, executable: str = CHROMIUM_PATH) -> None:
        if not Path(executable).is_file():
            raise SnapshotError(
                f"Chromium is needed for snapshots but {executable} does not exist: "
                "install it with `apt-get install chromium` (Debian/Ubuntu)"
            )
        try:
            from playwright.sync_api import sync_playwright
        except ImportError as exc:  # pragma: no cover - dependency of taskspace
            raise SnapshotError("snapshots need Python playwright: pip install playwright") from exc
        self._profile = tempfile.mkdtemp(prefix="taskspace-chromium-")
        self._playwright = sync_playwright().start()
        try:
            self.context = self._playwright.chromium.launch_persistent_context(
                self._profile,
                executable_path=executable,
                headless=True,
                args=list(CHROMIUM_ARGS),
                viewport={"width": 640, "height": 480},
                device_scale_factor=1,
            )
        except Exception as exc:
            self._playwright.stop()
            shutil.rmtree(self._profile, ignore_errors=True)
            raise SnapshotError(f"cannot start Chromium ({executable}): {exc}") from exc
        self.lock = threading.Lock()

    def close(self) -> None:
        """Close the browser and delete its profile directory."""
        try:
            self.context.close()
        finally:
            self._playwright.stop()
            shutil.rmtree(self._profile, ignore_errors=True)


class _BrowserThread:
    """The thread that owns the process-wide :class:`BrowserSession`; runs jobs in order.

    Before, the session belonged to whichever thread made the first snapshot: a snapshot from
    any other thread failed ("Cannot switch to a different thread"), and once that thread had
    ended, no snapshot worked and the exit printed a greenlet traceback.
    """

    def __init__(self) -> None:
        self.session: BrowserSession | None = None
        self._jobs: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="taskspace-browser", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            fn, future = job
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(fn())
            except BaseException as exc:  # handed to the caller
                future.set_exception(exc)

    def submit(self, fn: Any) -> concurrent.futures.Future[Any]:
        future: concurrent.futures.Future[Any] = concurrent.futures.Future()
        self._jobs.put((fn, future))
        return future

    def ensure_session(self) -> BrowserSession:
        """The session (started on first use); call on the browser thread only."""
        if self.session is None:
            self.session = BrowserSession()
        return self.session

    def close(self, timeout: float) -> None:
        def close_session() -> None:
            session, self.session = self.session, None
            if session is not None:
                session.close()

        future = self.submit(close_session)
        self._jobs.put(None)
        try:
            future.result(timeout=timeout)
        except concurrent.futures.TimeoutError:
            logger.warning("the snapshot browser did not close within %.0f s", timeout)


_BROWSER: _BrowserThread | None = None
_BROWSER_LOCK = threading.Lock()


def _browser_thread() -> _BrowserThread:
    global _BROWSER
    with _BROWSER_LOCK:
        if _BROWSER is None:
            _BROWSER = _BrowserThread()
            atexit.register(close_browser)
        return _BROWSER


def close_browser() -> None:
    """Close the process-wide browser (a later snapshot starts a new one)."""
    global _BROWSER
    with _BROWSER_LOCK:
        browser, _BROWSER = _BROWSER, None
    if browser is not None:
        browser.close(timeout=30.0)


def _html_source(scene_or_html: Any) -> tuple[Path, Path | None, str | None]:
    """(file to load, temporary file to delete, expected token) for a scene or HTML."""
    from taskspace.viz.scene_recorder import SceneRecorder
    from taskspace.viz.viewer import Viewer

    token: str | None = None
    html: str | None = None
    # the page is read once from a temporary file: the fastest compression
    if isinstance(scene_or_html, Viewer):
        html = scene_or_html.static_html(level=1)
        token = scene_or_html.recorder.token
    elif isinstance(scene_or_html, SceneRecorder):
        html = scene_or_html.static_html(level=1)
        token = scene_or_html.token
    elif isinstance(scene_or_html, Path):
        if not scene_or_html.is_file():
            raise InvalidInputError(f"HTML file not found: {scene_or_html}")
        return scene_or_html.resolve(), None, None
    elif isinstance(scene_or_html, str):
        if "<" not in scene_or_html[:1000]:
            path = Path(scene_or_html)
            if not path.is_file():
                raise InvalidInputError(
                    f"expected HTML text or an existing .html file, got {scene_or_html[:80]!r}"
                )
            return path.resolve(), None, None
        html = scene_or_html
    else:
        raise InvalidInputError(
            "snapshot needs a Viewer, a SceneRecorder, HTML text or a path to an HTML file; "
            f"got {type(scene_or_html).__name__}"
        )
    tmp = tempfile.NamedTemporaryFile("w", suffix=".html", delete=False, encoding="utf-8")
    with tmp:
        tmp.write(html)
    return Path(tmp.name), Path(tmp.name), token


def render_html(
    scene_or_html: Any,
    size: tuple[int, int] = (640, 480),
    options: SnapshotOptions | None = None,
) -> SnapshotResult:
    """Render a scene or static meshcat HTML in headless Chromium; return a :class:`SnapshotResult`.

    Args:
        scene_or_html: a :class:`~taskspace.viz.Viewer`, a
            :class:`~taskspace.viz.scene_recorder.SceneRecorder`, HTML text, or a path to an
            HTML file.
        size: image ``(width, height)`` [px].
        options: timeouts and network policy.

    Raises:
        SnapshotError: Chromium missing or failing, the scene not ready within the timeout,
            or JavaScript errors on the page that ``options.allowed_page_errors`` does not
            allow (the error's ``page_errors`` lists them).
    """
    opts = options if options is not None else SnapshotOptions()
    if not isinstance(opts, SnapshotOptions):
        raise InvalidInputError(f"options must be SnapshotOptions, got {type(opts).__name__}")
    width, height = check_size(size)
    source, temporary, token = _html_source(scene_or_html)
    cancel = threading.Event()
    browser = _browser_thread()
    future = browser.submit(
        lambda: _render_on_browser_thread(
            browser, source, token, (width, height), opts, cancel, temporary
        )
    )
    try:
        result: SnapshotResult = future.result()
    except BaseException:
        cancel.set()  # Ctrl-C: the browser thread abandons the page at its next poll
        if future.cancel() and temporary is not None:
            temporary.unlink(missing_ok=True)  # never started: nobody else deletes it
        raise
    allowed = opts.allowed_page_errors
    refused = [e for e in result.page_errors if not any(a in e for a in allowed)]
    for message in result.page_errors:
        if message not in refused:
            logger.info("snapshot page (allowed): %s", message)
    if refused:
        shown = "; ".join(refused[:5]) + (
            f"; ... ({len(refused)} in all)" if len(refused) > 5 else ""
        )
        raise SnapshotError(
            f"the snapshot page had {len(refused)} JavaScript error(s): {shown} (the image may "
            "be wrong or incomplete; allow known harmless ones with "
            "SnapshotOptions(allowed_page_errors=(...)))",
            refused,
        )
    return result


def _render_on_browser_thread(
    browser: _BrowserThread,
    source: Path,
    token: str | None,
    size: tuple[int, int],
    opts: SnapshotOptions,
    cancel: threading.Event,
    temporary: Path | None,
) -> SnapshotResult:
    """The body of :func:`render_html`, run on the browser's own thread."""
    width, height = size
    start = time.perf_counter()
    blocked: list[str] = []
    errors: list[str] = []
    try:
        session = browser.ensure_session()
        with session.lock:
            page = session.context.new_page()
            try:
                page.set_viewport_size({"width": width, "height": height})
                page.on("pageerror", lambda exc: errors.append(f"pageerror: {exc}"))
                page.on(
                    "console",
                    lambda msg: (
                        errors.append(f"console: {msg.text}") if msg.type == "error" else None
                    ),
                )
                if opts.offline:

                    def _route(route: Any) -> None:
                        url = route.request.url
                        if url.startswith(("file:", "data:", "blob:", "about:")):
                            route.continue_()
                        else:
                            blocked.append(url)
                            route.abort()

                    page.route("**/*", _route)
                page.goto(source.as_uri(), wait_until="load", timeout=opts.timeout * 1000)
                seen, captures, still, png = _wait_ready(page, token, opts, start, cancel)
                errors.extend(page.evaluate("() => window.__taskspace_errors || []"))
            finally:
                page.close()
    except SnapshotError:
        raise
    except Exception as exc:  # playwright errors (timeouts, crashes)
        raise SnapshotError(f"rendering {source.name} in Chromium failed: {exc}") from exc
    finally:
        if temporary is not None:
            temporary.unlink(missing_ok=True)
    return SnapshotResult(
        png=png,
        success=seen is not None and still,
        token=seen,
        captures=captures,
        blocked_requests=blocked,
        page_errors=errors,
        seconds=time.perf_counter() - start,
    )


def check_size(size: Any) -> tuple[int, int]:
    """Validate an image size ``(width, height)``: two integers in 16..4096 [px].

    Raises:
        InvalidInputError: otherwise (the message gives the valid range).
    """
    if isinstance(size, (str, bytes)) or not isinstance(size, Sequence | np.ndarray):
        raise InvalidInputError(f"size must be (width, height) in pixels, got {size!r}")
    if (isinstance(size, np.ndarray) and size.ndim != 1) or len(size) != 2:
        raise InvalidInputError(f"size must be (width, height) in pixels, got {size!r}")
    width, height = (check_int(s, "size (width, height) [px]") for s in size)
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise InvalidInputError(
            f"size (width, height) must be within 16..4096 pixels each, got {size!r}"
        )
    return width, height


def _wait_ready(
    page: Any,
    token: str | None,
    opts: SnapshotOptions,
    start: float,
    cancel: threading.Event | None = None,
) -> tuple[str | None, int, bool, bytes]:
    """Poll the readiness token, then screenshots until ``stable_captures`` agree.

    Returns ``(token, captures, still, last screenshot)``.

    Raises:
        SnapshotError: not ready within the timeout, or ``cancel`` set (the caller is gone).
    """
    deadline = start + opts.timeout

    def check_cancel() -> None:
        if cancel is not None and cancel.is_set():
            raise SnapshotError("the snapshot was cancelled (its caller was interrupted)")

    seen: str | None = None
    while time.perf_counter() < deadline:
        check_cancel()
        seen = page.evaluate(_READY_JS)
        if seen is not None and (token is None or seen == token):
            break
        page.wait_for_timeout(opts.poll_interval * 1000)
    else:
        raise SnapshotError(
            f"the scene did not become ready within {opts.timeout:.0f} s (readiness token "
            f"{'never seen' if seen is None else 'mismatch: ' + seen})"
        )
    if opts.animation_time is not None:
        page.evaluate(_PAUSE_JS, float(opts.animation_time))
    page.add_style_tag(content=HIDE_CONTROLS_CSS)
    previous = None
    identical = 0
    captures = 0
    while time.perf_counter() < deadline:
        check_cancel()
        capture = page.screenshot(type="png", full_page=False)
        captures += 1
        if capture == previous:
            identical += 1
            if identical >= opts.stable_captures - 1:
                return seen, captures, True, capture
        else:
            identical = 0
        previous = capture
        page.wait_for_timeout(opts.poll_interval * 1000)
    logger.warning("scene still changing after %.0f s (animation playing?)", opts.timeout)
    return seen, captures, False, previous if previous is not None else b""


def snapshot(
    scene_or_html: Any,
    path: str | Path | None = None,
    size: tuple[int, int] = (640, 480),
    *,
    options: SnapshotOptions | None = None,
) -> bytes:
    """Render a scene (or its static HTML) to a PNG image.

    Args:
        scene_or_html: a :class:`~taskspace.viz.Viewer`, a scene recorder, HTML text or a
            path to an HTML file.
        path: also write the PNG there (parent directories are created).
        size: image ``(width, height)`` [px].
        options: timeouts and network policy (:class:`SnapshotOptions`).

    Returns:
        The PNG bytes.

    Raises:
        SnapshotError: Chromium is missing (``apt-get install chromium``) or the scene did
            not become ready.
    """
    if path is not None:
        check_png_path(path)  # before the seconds of rendering
    result = render_html(scene_or_html, size, options)
    if not result.success:
        raise SnapshotError(
            f"the scene did not settle after {result.captures} screenshots "
            f"({result.seconds:.1f} s); is an animation playing?"
        )
    if path is not None:
        write_output(path, result.png)
    return result.png


def check_output_path(path: Any) -> Path:
    """An output file path, refused if it cannot be a file (checked before any rendering).

    Raises:
        InvalidInputError: not a path, an existing directory, or under an existing file.
    """
    if not isinstance(path, (str, Path)) or not str(path):
        raise InvalidInputError(f"path must be a file name (str or Path), got {path!r}")
    out = Path(path)
    if out.is_dir():
        raise InvalidInputError(f"{out} is a directory; give a file name, e.g. {out / 'scene'}")
    for parent in out.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InvalidInputError(f"cannot write {out}: {parent} is a file")
            break
    return out


def check_png_path(path: Any) -> Path:
    """:func:`check_output_path` for PNG data: a suffix other than ``.png`` is refused.

    PNG bytes in ``x.jpg`` made a file that image tools reject or misread (``taskspace
    snapshot --png x.jpg`` wrote one). Refused rather than converted: the snapshot is PNG.

    Raises:
        InvalidInputError: as :func:`check_output_path`, or a suffix other than ``.png``.
    """
    out = check_output_path(path)
    if out.suffix and out.suffix.lower() != ".png":
        raise InvalidInputError(
            f"{out}: a snapshot is PNG data; name the file {out.with_suffix('.png').name} "
            f"(for {out.suffix}, convert it: PIL.Image.open(io.BytesIO(png)).save(...))"
        )
    return out


def write_output(path: Any, data: bytes) -> Path:
    """Write ``data`` to ``path`` (parent directories are created).

    Raises:
        InvalidInputError: the path cannot be written (the OS error is the cause).
    """
    out = check_output_path(path)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(data)
    except OSError as exc:
        raise InvalidInputError(f"cannot write {out}: {exc.strerror or exc}") from exc
    return out
