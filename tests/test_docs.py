"""The documentation builds with warnings as errors, with its API pages and its gallery.

Runs ``python -m sphinx -W --keep-going -b html docs <tmp>`` (the same command as
``make docs``, into a temporary directory) with ``TASKSPACE_FAST=1``. Every example gets its
gallery page, but this build runs only the examples of ``GALLERY_EXAMPLES``, the ones whose
embedded figures :func:`test_gallery_pages_have_the_figures` checks (a matplotlib figure, a
figure of an example in a subfolder, a meshcat snapshot rendered by headless Chromium): it
narrows ``docs/conf.py``'s gallery with ``TASKSPACE_DOCS_GALLERY``. Every example, these
three included, is run by ``tests/test_cli_demos.py::test_every_demo_accepts_every_flag``
(with each flag, its outputs checked), so running the others here again would test nothing
more. ``make docs`` runs them all.
"""

from __future__ import annotations

import functools
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

try:
    import fcntl
except ImportError:  # pragma: no cover (Windows: no lock, one build per worker)
    fcntl = None  # type: ignore[assignment]

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
TIMEOUT = 1200  # seconds for the whole build
GALLERY_EXAMPLES = ("ik/panda_reach_obstacle", "control/cartpole_lqr", "demo_main")
"""The examples the build of this test runs (paths in ``examples/``, without ``.py``)."""
GALLERY_PATTERN = (
    r"[/\\]("
    + "|".join(r"[/\\]".join(map(re.escape, e.split("/"))) for e in GALLERY_EXAMPLES)
    + r")\.py$"
)
"""sphinx-gallery's ``filename_pattern`` (searched in each script's path) for them."""

pytest.importorskip("sphinx")
pytest.importorskip("sphinx_gallery")

# Every test here shares one build: keep them on one xdist worker (--dist loadgroup) so the
# other worker goes on with the rest of the suite.
pytestmark = pytest.mark.xdist_group("docs_build")


def _shared_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory shared by every xdist worker of this session (the session's basetemp)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def _build(out: Path) -> dict[str, object]:
    env = dict(
        os.environ,
        TASKSPACE_FAST="1",
        MPLBACKEND="Agg",
        OPENBLAS_NUM_THREADS="1",
        TASKSPACE_DOCS_GALLERY=GALLERY_PATTERN,
    )
    env.pop("DISPLAY", None)
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    start = time.perf_counter()
    proc = subprocess.run(
        [*command, "-d", str(out / ".doctrees"), str(DOCS), str(out)],
        cwd=str(ROOT),
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )
    return {
        "returncode": proc.returncode,
        "stdout": proc.stdout[-4000:],
        "stderr": proc.stderr[-6000:],
        "seconds": time.perf_counter() - start,
        "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"),
    }


@pytest.fixture(scope="module")
def html(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built once per test session.

    The build runs under an exclusive file lock in a directory shared by the xdist workers
    and records its outcome there, so a worker that reaches this fixture later (a rescheduled
    or restarted worker) reuses that build instead of starting a second one.
    """
    shared = _shared_dir(tmp_path_factory)
    out = shared / "docs_html"
    record = shared / "docs_build.json"
    with open(shared / "docs_build.lock", "w") as lock:
        if fcntl is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)
        if not record.is_file():
            out.mkdir(exist_ok=True)
            record.write_text(json.dumps(_build(out)), encoding="utf-8")
            with open(shared / "docs_builds.log", "a", encoding="utf-8") as log:
                log.write(os.environ.get("PYTEST_XDIST_WORKER", "main") + "\n")
    result = json.loads(record.read_text(encoding="utf-8"))
    assert result["returncode"] == 0, (
        f"sphinx exited with {result['returncode']}\n--- stdout ---\n{result['stdout']}"
        f"\n--- stderr ---\n{result['stderr']}"
    )
    return out


@pytest.mark.slow
@pytest.mark.parametrize(
    ("page", "needle"),
    [
        ("taskspace.ik.DifferentialIK", "step"),
        ("taskspace.model.Robot", "load"),
        ("taskspace.qp.QPSolver", "QPSolver"),
        ("taskspace.planning.rrt_connect", "rrt_connect"),
        ("taskspace.control.InverseDynamicsQP", "InverseDynamicsQP"),
        ("taskspace.estimation.KalmanFilter", "KalmanFilter"),
    ],
)
def test_api_page_of_key_objects(html: Path, page: str, needle: str) -> None:
    path = html / "_generated" / "api" / "stubs" / f"{page}.html"
    assert path.is_file(), f"no API page {path.name}"
    text = path.read_text(encoding="utf-8")
    assert needle in text
    assert "Parameters" in text or "Returns" in text or "Attributes" in text


@pytest.mark.slow
def test_user_guide_links_the_api(html: Path) -> None:
    page = (html / "guide" / "inverse_kinematics.html").read_text(encoding="utf-8")
    # a resolved cross-reference is a link to the object's API page
    assert "stubs/taskspace.ik.DifferentialIK.html" in page
    assert "stubs/taskspace.ik.solve_ik.html" in page


@pytest.mark.slow
def test_gallery_pages_have_the_figures(html: Path) -> None:
    gallery = html / "_generated" / "gallery"
    assert (gallery / "index.html").is_file()
    examples = sorted(
        p.relative_to(ROOT / "examples").with_suffix(".html")
        for p in (ROOT / "examples").rglob("*.py")
        if not p.name.startswith("_") and "__pycache__" not in p.parts
    )
    missing = [str(e) for e in examples if not (gallery / e).is_file()]
    assert not missing, f"gallery pages missing: {missing}"
    # the examples this build runs: the PNGs they save are embedded in their pages
    for example in GALLERY_EXAMPLES:
        page = (gallery / f"{example}.html").read_text(encoding="utf-8")
        assert "sphx-glr-single-img" in page or "sphx-glr-multi-img" in page, example
        assert ".png" in page, example
    # a meshcat snapshot (headless Chromium) is embedded too
    images = {p.name for p in (html / "_images").glob("*.png")}
    assert any(name.startswith("sphx_glr_demo_main") for name in images), sorted(images)[:20]


# ----------------------------------------------------------------------------- fast checks
def test_gallery_pattern_selects_exactly_the_checked_examples() -> None:
    """The pattern given to the build runs the examples of ``GALLERY_EXAMPLES``, no other."""
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import taskspace_gallery
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    # the paths sphinx-gallery searches: the scripts of the mirror of examples/
    mirrored = [
        taskspace_gallery.GALLERY_SRC / p.relative_to(ROOT / "examples")
        for p in sorted((ROOT / "examples").rglob("*.py"))
        if not p.name.startswith("_") and "__pycache__" not in p.parts
    ]
    selected = [
        p.relative_to(taskspace_gallery.GALLERY_SRC).with_suffix("").as_posix()
        for p in mirrored
        if re.search(GALLERY_PATTERN, str(p))
    ]
    assert sorted(selected) == sorted(GALLERY_EXAMPLES)
    assert re.search(GALLERY_PATTERN, str(DOCS / "x" / "ik" / "panda_reach_obstacle.py"))
    assert not re.search(GALLERY_PATTERN, str(DOCS / "x" / "ik" / "not_panda_reach_obstacle.py"))


SPHINX_ROLE_NOISE = ("Unknown interpreted text role", "No role entry", "Trying ")


@functools.cache
def _docutils_settings() -> tuple[object, object]:
    from docutils.frontend import get_default_settings
    from docutils.parsers.rst import Parser

    quiet = get_default_settings(Parser)
    quiet.report_level = 5
    loud = get_default_settings(Parser)
    loud.report_level, loud.halt_level = 5, 5  # observed below, never printed
    return quiet, loud


def summary_problems(doc: str) -> list[str]:
    """Warnings docutils gives for autosummary's summary (first sentence) of ``doc``."""
    from docutils.parsers.rst import Parser
    from docutils.utils import new_document
    from sphinx.ext.autosummary import extract_summary

    first = " ".join(doc.strip().split("\n\n")[0].split())
    if not (re.search(r"\.\s", first) and re.search(r"[`*|]", first)):
        return []  # not cut, or no inline markup a cut could break
    quiet, loud = _docutils_settings()
    summary = extract_summary(doc.splitlines(), quiet)
    document = new_document("<autosummary>", loud)
    messages: list[str] = []
    document.reporter.attach_observer(
        lambda m: messages.append(m.astext()) if int(m["level"]) >= 2 else None
    )
    Parser().parse(summary, document)
    return [m for m in messages if not any(noise in m for noise in SPHINX_ROLE_NOISE)]


def test_summary_check_catches_a_cut_inline_literal() -> None:
    bad = "Learn from exactly one period ``times[0] .. times[-1]`` of a periodic motion."
    assert summary_problems(bad), "autosummary cuts this sentence inside the literal"
    assert not summary_problems(bad.replace("``times[0] .. times[-1]``", "(t0 to t1)"))


def test_api_summaries_are_valid_rest() -> None:
    """Autosummary tables show each object's first sentence: it must parse without warnings.

    Autosummary cuts the first paragraph at the first ". " even inside an inline literal;
    the docs build (-W) then fails on ":1:<autosummary>:1: Inline literal start-string
    without end-string" without naming the object. This finds it in seconds.
    """
    import importlib
    import inspect

    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import taskspace_api
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    problems = {}
    for page in [f"taskspace.{name}" for name in taskspace_api.public_packages()]:
        module = importlib.import_module(page)
        for name in taskspace_api._exported(module):
            obj = getattr(module, name, None)
            members = [(name, obj)]
            if inspect.isclass(obj):
                members += [
                    (f"{name}.{m}", v) for m, v in vars(obj).items() if not m.startswith("_")
                ]
            for qualified, member in members:
                doc = inspect.getdoc(member)
                if doc and (found := summary_problems(doc)):
                    problems[f"{page}.{qualified}"] = found
    assert not problems, problems


def _attributes_section(doc: str) -> list[str]:
    """Names listed in the Google-style ``Attributes:`` section of a class docstring."""
    match = re.search(r"^Attributes:\n((?:[ \t]+.*\n?|\n)*)", doc, re.M)
    if not match:
        return []
    return re.findall(r"^    (\w+)\s*(?:\([^)]*\))?:", match.group(1), re.M)


def test_attributes_sections_do_not_repeat_documented_members() -> None:
    """A property (or NamedTuple field) listed under ``Attributes:`` is documented twice.

    napoleon turns the section into attribute directives and autodoc documents the member
    itself: Sphinx then warns "duplicate object description" and the -W build fails.
    """
    import importlib
    import inspect

    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import taskspace_api
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    repeated = {}
    for page in [f"taskspace.{name}" for name in taskspace_api.public_packages()]:
        module = importlib.import_module(page)
        for name in taskspace_api._exported(module):
            cls = getattr(module, name, None)
            if not inspect.isclass(cls):
                continue
            members = vars(cls)
            twice = [
                a
                for a in _attributes_section(inspect.getdoc(cls) or "")
                if isinstance(members.get(a), property)
                or type(members.get(a)).__name__ == "_tuplegetter"
            ]
            if twice:
                repeated[f"{page}.{name}"] = twice
    assert not repeated, repeated


def test_attribute_check_sees_a_property() -> None:
    doc = "A thing.\n\nAttributes:\n    name: its name.\n    size (int): its size [m].\n"
    assert _attributes_section(doc) == ["name", "size"]
