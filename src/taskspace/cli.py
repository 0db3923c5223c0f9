"""The ``taskspace`` command: robots, demos, benchmarks and snapshots.

Usage::

    taskspace info
    taskspace robots
    taskspace demo list
    taskspace demo NAME [--html FILE] [--png FILE] [--save DIR] [--no-viewer] [example args...]
    taskspace bench [SUITE ...] [--quick] [--save FILE] | bench --compare A.json B.json
    taskspace snapshot ROBOT [--q "0,0.1,..."] --png out.png [--html out.html] [--geometry G]

``demo NAME`` runs an example script of ``examples/`` found by its file stem (``bug_paths``)
or by ``topic/stem`` (``planning/bug_paths``); ``main`` is ``examples/demo_main.py``. Every
demo accepts the same output flags, paths relative to the caller's directory: ``--save DIR``
(everything the example writes), ``--png FILE`` (its picture: the meshcat snapshot, else its
first figure), ``--html FILE`` (its meshcat animation, else a page of its figures) and
``--no-viewer`` (no live viewer, no figure window). Bad arguments exit with status 2 and a
message naming the valid choices.
"""

from __future__ import annotations

import argparse
import ast
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from taskspace.errors import TaskspaceError

logger = logging.getLogger(__name__)

REPO_ROOT = Path(__file__).resolve().parents[2]
"""Source tree root when taskspace is installed editable (benchmarks live there)."""


def _examples_dir() -> Path:
    """The examples: the checkout's ``examples/`` (editable install), else the copy in the wheel.

    A wheel ships ``examples/`` as ``taskspace/examples`` (pyproject.toml ``wheel.packages``),
    so ``taskspace demo`` works from an installed copy too.
    """
    checkout = REPO_ROOT / "examples"
    if (checkout / "demo_main.py").is_file():
        return checkout
    return Path(__file__).resolve().parent / "examples"


EXAMPLES_DIR = _examples_dir()
"""Where ``taskspace demo`` finds its scripts (see :func:`_examples_dir`)."""

DEMO_ALIASES = {"main": "demo_main"}
"""Short demo names mapped to example stems."""


class CliError(TaskspaceError):
    """A bad command-line argument (reported with exit status 2)."""


# ---------------------------------------------------------------------- examples
def discover_examples(root: Path = EXAMPLES_DIR) -> dict[str, Path]:
    """Runnable examples by name: ``topic/stem`` for every script, plus ``stem`` when unique.

    Files whose name starts with ``_`` (shared helpers) are skipped.
    """
    found: dict[str, Path] = {}
    stems: dict[str, list[Path]] = {}
    if not root.is_dir():
        return found
    for path in sorted(root.rglob("*.py")):
        if path.name.startswith("_") or any(p.startswith(("_", ".")) for p in path.parts[-3:-1]):
            continue
        rel = path.relative_to(root).with_suffix("").as_posix()
        found[rel] = path
        stems.setdefault(path.stem, []).append(path)
    for stem, paths in stems.items():
        if len(paths) == 1 and stem not in found:
            found[stem] = paths[0]
    for alias, target in DEMO_ALIASES.items():
        if target in found:
            found[alias] = found[target]
    return found


def example_description(path: Path) -> str:
    """First paragraph of an example's module docstring, on one line (the script is not run)."""
    try:
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    except (OSError, SyntaxError, ValueError):
        return ""
    return " ".join(doc.strip().split("\n\n")[0].split())


def demo_listing(root: Path = EXAMPLES_DIR) -> list[tuple[str, str]]:
    """Each demo once: ``(shortest name, one-line description)``, in folder order.

    The shortest name is the alias (``main``), else the file stem when unique, else
    ``topic/stem``.
    """
    names: dict[Path, list[str]] = {}
    for name, path in discover_examples(root).items():
        names.setdefault(path, []).append(name)
    rows = []
    for path, aliases in names.items():
        short = min(aliases, key=lambda n: (n not in DEMO_ALIASES, n.count("/"), len(n)))
        rows.append((short, example_description(path)))
    rank = {p: i for i, p in enumerate(sorted(names, key=lambda p: (p.parent != root, p)))}
    order = {short: rank[path] for (short, _), path in zip(rows, names)}
    return sorted(rows, key=lambda row: order[row[0]])


def _example_path(name: str) -> Path:
    examples = discover_examples()
    if name not in examples:
        valid = ", ".join(sorted(examples)) or "(none found in examples/)"
        raise CliError(f"unknown demo '{name}'; valid demos are: {valid}")
    return examples[name]


# ---------------------------------------------------------------------- commands
def cmd_robots(args: argparse.Namespace) -> int:
    """Print every robot ``Robot.load`` accepts: nq, nv, floating base, source, end-effectors.

    Sizes come from the kinematic trees (no meshes) and are cached on disk, so the listing
    takes well under a second once the cache is filled.
    """
    from taskspace.model.registry import available_robots, robot_summaries

    summaries: dict[str, dict[str, Any]]
    if args.no_load:
        specs = available_robots()
        summaries = {
            n: {
                "nq": None,
                "nv": None,
                "floating": s.free_flyer,
                "source": "registry" if s.in_registry else "example-robot-data",
                "end_effectors": s.end_effectors,
                "description": s.description,
            }
            for n, s in specs.items()
        }
    else:
        summaries = robot_summaries(
            progress=lambda names: _progress(names, "reading robot descriptions (once)")
        )
    header = ("name", "nq", "nv", "floating", "source", "end-effectors", "description")
    table = []
    for name, info in summaries.items():
        nq = "?" if info.get("error") else ("-" if info["nq"] is None else str(info["nq"]))
        nv = "?" if info.get("error") else ("-" if info["nv"] is None else str(info["nv"]))
        description = str(info["description"])
        if info.get("error"):
            description = f"{description} (cannot be read: {str(info['error'])[:80]})"
        table.append(
            (
                name,
                nq,
                nv,
                "yes" if info["floating"] else "no",
                info["source"],
                ", ".join(info["end_effectors"]) or "-",
                description,
            )
        )
    n_cols = len(header) - 1
    widths = [max(len(str(r[i])) for r in [header, *table]) for i in range(n_cols)]
    lines = [
        "  ".join(str(c).ljust(w) for c, w in zip(header[:n_cols], widths)) + "  " + header[-1]
    ]
    lines.append("  ".join("-" * w for w in widths) + "  " + "-" * 11)
    for r in table:
        lines.append("  ".join(str(c).ljust(w) for c, w in zip(r[:n_cols], widths)) + "  " + r[-1])
    print("\n".join(lines))
    return 0


DEMO_FLAGS = ("--html", "--png", "--save", "--no-viewer")
"""Output flags every demo accepts through ``taskspace demo``."""


def native_flags(path: Path) -> set[str]:
    """The flags of :data:`DEMO_FLAGS` that an example's own argparse defines.

    Read from the script's source (an ``add_argument("--html", ...)`` call); ``--save`` is
    always there (every example writes its figures with ``--save DIR``).
    """
    text = path.read_text(encoding="utf-8")
    found = {flag for flag in DEMO_FLAGS if f'"{flag}"' in text or f"'{flag}'" in text}
    return found | {"--save"}


def _caller_path(text: str | None) -> Path | None:
    """A path argument made absolute against the caller's working directory."""
    return None if not text else Path(os.path.abspath(Path(text).expanduser()))


def _check_output_file(flag: str, text: str | None) -> None:
    """Refuse an output path that cannot be a file before any work is done.

    Raises:
        CliError: the path is a directory, or a parent of it is an existing non-directory;
            ``--png`` with a suffix other than ``.png``.
    """
    path = _caller_path(text)
    if path is None:
        return
    if path.is_dir():
        raise CliError(f"{flag} {text}: is a directory; give a file name, e.g. {path / 'out'}")
    if flag == "--png" and path.suffix and path.suffix.lower() != ".png":
        # PNG bytes went into x.jpg (refused rather than converted: the picture is PNG)
        raise CliError(
            f"{flag} {text}: the picture is PNG data; name the file {path.with_suffix('.png').name}"
        )
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise CliError(f"{flag} {text}: {parent} is a file, not a directory")
            if not os.access(parent, os.W_OK):
                raise CliError(f"{flag} {text}: cannot write into {parent} (permission denied)")
            break


def _picture(folder: Path, stem: str) -> Path | None:
    """The demo's picture: the robot (``<stem>_robot.png``, a snapshot), else ``<stem>.png``."""
    pngs = sorted(folder.rglob("*.png"))
    ranks = (
        lambda p: p.stem == f"{stem}_robot",
        lambda p: "snapshot" in p.stem,
        lambda p: p.stem == stem,
        lambda p: True,
    )
    for rank in ranks:
        chosen = [p for p in pngs if rank(p)]
        if chosen:
            return chosen[0]
    return None


def cmd_demo(args: argparse.Namespace, extra: list[str]) -> int:
    """Run an example script in a subprocess (its own imports and argparse apply).

    The subprocess runs in the caller's directory with absolute output paths. Flags the
    script does not define itself are provided here: the script writes into ``--save`` (a
    temporary directory when only ``--png``/``--html`` were asked), then its picture is copied
    to ``--png`` and its HTML (or a page of its figures) to ``--html``. ``--no-viewer`` also
    sets ``MPLBACKEND=Agg`` (no figure window).
    """
    from taskspace.viz.figure_page import save_figure_page

    path = _example_path(args.name)
    for flag, text in (("--png", args.png), ("--html", args.html)):
        _check_output_file(flag, text)
    save_path = _caller_path(args.save)
    if save_path is not None and save_path.exists() and not save_path.is_dir():
        raise CliError(f"--save {args.save}: is a file; give a directory")
    html, png, save = (_caller_path(x) for x in (args.html, args.png, args.save))
    native = native_flags(path)
    forwarded = list(extra)
    env = dict(os.environ)
    asked = (("--html", html), ("--png", png))
    missing = [flag for flag, value in asked if value is not None and flag not in native]
    temporary = None
    out_dir = save
    if out_dir is None and missing:
        temporary = tempfile.TemporaryDirectory(prefix="taskspace-demo-")
        out_dir = Path(temporary.name)
    if out_dir is not None:
        forwarded += ["--save", str(out_dir)]
    if html is not None and "--html" in native:
        forwarded += ["--html", str(html)]
    if png is not None and "--png" in native:
        forwarded += ["--png", str(png)]
    if args.no_viewer:
        env["MPLBACKEND"] = "Agg"
        if "--no-viewer" in native:
            forwarded.append("--no-viewer")
    command = [sys.executable, str(path), *forwarded]
    logger.info("running %s", " ".join(command))
    shown = path.relative_to(REPO_ROOT) if path.is_relative_to(REPO_ROOT) else path
    print(f"# running {shown} {' '.join(forwarded)}".rstrip(), flush=True)
    try:
        code = _run_until_done(command, env)
        if code != 0 or out_dir is None:
            return code
        if png is not None and "--png" not in native:
            picture = _picture(out_dir, path.stem)
            if picture is None:
                raise CliError(f"demo '{args.name}' wrote no picture for --png")
            if picture.resolve() != png:
                png.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(picture, png)
            print(f"wrote {png}")
        if html is not None and "--html" not in native:
            pages = sorted(out_dir.rglob("*.html"))
            if pages:
                html.parent.mkdir(parents=True, exist_ok=True)
                if pages[0].resolve() != html:
                    shutil.copyfile(pages[0], html)
            else:
                figures = sorted(out_dir.rglob("*.png"))
                if not figures:
                    raise CliError(f"demo '{args.name}' wrote no figure or scene for --html")
                save_figure_page(html, figures, title=f"taskspace demo {args.name}")
            print(f"wrote {html}")
        return 0
    finally:
        if temporary is not None:
            temporary.cleanup()


_QUIET_INTERRUPT = """\
import os, runpy, sys
del sys.argv[0]
try:
    if sys.argv[0] == "-m":
        del sys.argv[0]
        runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
    else:
        sys.path[0] = os.path.dirname(os.path.abspath(sys.argv[0]))
        runpy.run_path(sys.argv[0], run_name="__main__")
except KeyboardInterrupt:
    raise SystemExit(130) from None
"""
"""Runs ``SCRIPT ARGS...`` or ``-m MODULE ARGS...`` as ``python`` would (``__main__``,
``sys.argv``, ``sys.path[0]``), except that Ctrl-C exits with status 130 without a traceback."""


def _run_until_done(command: list[str], env: dict[str, str]) -> int:
    """Run ``command`` (``[python, SCRIPT | -m MODULE, ARGS...]``); on Ctrl-C exit 130.

    The child got the same SIGINT from the terminal: it is let stop by itself (its cleanup
    runs) and exits 130 without a traceback (see :data:`_QUIET_INTERRUPT`).
    """
    python, *rest = command
    proc = subprocess.Popen([python, "-c", _QUIET_INTERRUPT, *rest], env=env)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.terminate()
            proc.wait()
        raise  # main() reports it and exits 130


def cmd_bench(args: argparse.Namespace) -> int:
    """Delegate to ``python -m benchmarks.run`` (the benchmark runner of the source tree)."""
    if not (REPO_ROOT / "benchmarks" / "run.py").is_file():
        raise CliError(f"benchmarks/run.py not found under {REPO_ROOT} (needs the source tree)")
    argv = list(args.suites)
    if args.quick:
        argv.append("--quick")
    if args.save:
        _check_output_file("--save", args.save)
        argv += ["--save", str(_caller_path(args.save))]
    if args.executor:
        argv += ["--executor", args.executor]
    if args.compare:
        files = [_caller_path(f) for f in args.compare]
        for f in files:
            if f is None or not f.is_file():
                raise CliError(f"--compare: no such results file {f}")
            _check_results_file(f)
        argv = ["--compare", *(str(f) for f in files)]
    else:
        unknown = [s for s in args.suites if s not in benchmark_suites()]
        if unknown:
            valid = ", ".join(benchmark_suites())
            raise CliError(f"unknown suite(s) {', '.join(unknown)}; valid suites are: {valid}")
    return _run_until_done([sys.executable, "-m", "benchmarks.run", *argv], _bench_env())


def _check_results_file(path: Path) -> None:
    """Refuse a ``--compare`` file that is not a saved run (JSON ``{"rows": [...]}``).

    Raises:
        CliError: the file is not JSON, or has no list of rows with suite, scene, method and
            timing.
    """
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise CliError(f"--compare: {path} is not a JSON file of saved results: {exc}") from None
    rows = data.get("rows") if isinstance(data, dict) else None
    keys = ("suite", "scene", "method", "timing")
    if not isinstance(rows, list) or not all(
        isinstance(r, dict) and all(k in r for k in keys) for r in rows
    ):
        raise CliError(
            f"--compare: {path} is not a run saved by `taskspace bench --save` (needs "
            f'{{"rows": [...]}} with {", ".join(keys)} in every row)'
        )


def _bench_env() -> dict[str, str]:
    """Environment of the benchmark runner: the source tree importable from any directory."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO_ROOT), env.get("PYTHONPATH")) if p)
    return env


def benchmark_suites() -> list[str]:
    """Names of the benchmark suites (``benchmarks/suites/<name>.py``), without importing them."""
    folder = REPO_ROOT / "benchmarks" / "suites"
    return sorted(p.stem for p in folder.glob("[!_]*.py")) if folder.is_dir() else []


def parse_configuration(text: str, nq: int) -> list[float]:
    """Parse ``--q "0,0.1,..."`` (commas and/or spaces) into ``nq`` numbers."""
    parts = [p for p in text.replace(",", " ").split() if p]
    values = []
    for p in parts:
        try:
            values.append(float(p))
        except ValueError:
            raise CliError(
                f"--q must be numbers separated by commas; '{p}' is not a number"
            ) from None
    if len(values) != nq:
        raise CliError(f"--q has {len(values)} values but the robot has nq = {nq}")
    return values


def cmd_snapshot(args: argparse.Namespace) -> int:
    """Render a robot at a configuration to PNG (and optionally static HTML)."""
    from taskspace.model import Robot
    from taskspace.model.registry import available_robots

    if args.robot not in available_robots():
        valid = ", ".join(sorted(available_robots()))
        raise CliError(f"unknown robot '{args.robot}'; valid robots are: {valid}")
    if not args.png and not args.html:
        raise CliError("give --png FILE and/or --html FILE")
    for flag, text in (("--png", args.png), ("--html", args.html)):
        _check_output_file(flag, text)
    if args.png and not (16 <= args.width <= 4096 and 16 <= args.height <= 4096):
        # before the robot is loaded and the HTML written (the PNG would fail after them)
        raise CliError(
            f"--width and --height must be within 16..4096 pixels each, got --width "
            f"{args.width} --height {args.height}"
        )
    robot = Robot.load(args.robot)
    q = robot.q_default if args.q is None else parse_configuration(args.q, robot.nq)
    if args.q is not None:
        from taskspace.errors import LimitError

        try:  # a configuration the robot cannot take is a usage error, not a picture
            robot.check_limits(q, tolerance=1e-9, name="--q")
        except LimitError as exc:
            raise CliError(str(exc)) from None
    from taskspace.viz import Viewer

    viewer = Viewer(robot, q, geometry=args.geometry)
    if args.frames:
        viewer.add_robot_frames()
    if args.html:
        out = viewer.save_html(_caller_path(args.html) or args.html)
        print(f"wrote {out}")
    if args.png:
        png = _caller_path(args.png) or Path(args.png)
        print("rendering the PNG snapshot in headless Chromium (a few seconds)...", flush=True)
        start = time.perf_counter()
        viewer.snapshot(png, size=(args.width, args.height))
        print(f"wrote {png} ({time.perf_counter() - start:.1f} s)")
    return 0


def _progress(items: Sequence[str], desc: str, enabled: bool = True) -> Sequence[str]:
    if not enabled or not sys.stderr.isatty():
        return items
    from tqdm import tqdm

    return tqdm(items, desc=desc, leave=False)  # type: ignore[return-value]


# ---------------------------------------------------------------------- info
def cmd_info(args: argparse.Namespace) -> int:
    """Versions of taskspace and of the libraries it runs on, and whether the kernels are used."""
    from importlib import metadata

    import taskspace
    from taskspace import _native

    def version(dist: str) -> str:
        if dist == "taskspace":
            return taskspace.__version__
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    rows = [(name, version(dist)) for name, dist in INFO_PACKAGES]
    kernels = [
        ("IK kernel (weighted and hierarchical differential IK)", _native.ik_kernel()),
        ("inverse-dynamics kernel (weighted ID-QP step)", _native.idqp_kernel()),
        (
            "planning kernel (RRT-Connect, collision check, curves, grasp epsilon)",
            _native.planning_kernel(),
        ),
    ]
    width = max(len(n) for n, _ in [*rows, *kernels])
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    for name, module in kernels:
        print(f"{name:<{width}}  {'compiled, in use' if module is not None else 'not in use'}")
    built = _native.build_info()
    if built:
        against = ", ".join(f"{k} {built.get(k, '?')}" for k in _native.CHECKED)
        print(f"\nkernels built against {against}; {built.get('arch', '?')} code")
    reason = _native.status()
    if reason:
        print(f"\nPython paths are used where a kernel is missing: {reason}")
    return 0


INFO_PACKAGES = (
    ("taskspace", "taskspace"),
    ("pinocchio", "pin"),
    ("coal", "coal"),
    ("proxsuite", "proxsuite"),
    ("qpsolvers", "qpsolvers"),
    ("meshcat", "meshcat"),
    ("example-robot-data", "example-robot-data"),
    ("numpy", "numpy"),
)
"""(name shown, distribution) of the packages ``taskspace info`` reports."""


# ---------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``taskspace``."""
    parser = argparse.ArgumentParser(
        prog="taskspace", description="taskspace: robots, demos, benchmarks, snapshots"
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log at INFO level")
    sub = parser.add_subparsers(dest="command", required=True)

    sub.add_parser("info", help="versions of the libraries and whether the compiled kernels run")

    p = sub.add_parser(
        "robots", help="list every robot: our registry and all of example-robot-data"
    )
    p.add_argument("--no-load", action="store_true", help="do not read the models (no nq/nv)")

    p = sub.add_parser(
        "demo",
        help="run an example by name ('main' is examples/demo_main.py; 'list' lists them)",
        description="Run an example of examples/ by name. Output paths are relative to the "
        "current directory. Other arguments go to the example itself.",
    )
    p.add_argument(
        "name", nargs="?", default="main", help="demo name (default: main), or 'list' to list them"
    )
    p.add_argument(
        "--html",
        metavar="FILE",
        help="write the meshcat animation (else a page of the figures) to FILE",
    )
    p.add_argument(
        "--png",
        metavar="FILE",
        help="write the demo's picture (meshcat snapshot, else first figure) to FILE",
    )
    p.add_argument("--save", metavar="DIR", help="write every figure, scene and snapshot into DIR")
    p.add_argument(
        "--no-viewer", action="store_true", help="no live meshcat viewer, no figure window"
    )

    suites = benchmark_suites()
    p = sub.add_parser(
        "bench",
        help="run benchmarks (python -m benchmarks.run)",
        description="Run benchmark suites and print median/p95 per scene, or compare two "
        "saved runs. Suites: " + (", ".join(suites) or "(benchmarks/ not found)") + ".",
    )
    p.add_argument(
        "suites", nargs="*", metavar="SUITE", help=f"suites to run (default: all): {suites}"
    )
    p.add_argument("--quick", action="store_true", help="small scenes, few repetitions")
    p.add_argument("--save", metavar="FILE", help="write results as JSON to FILE")
    p.add_argument(
        "--compare",
        nargs=2,
        metavar=("A", "B"),
        help="compare two saved runs (JSON of --save): times of B relative to A",
    )
    p.add_argument(
        "--executor",
        choices=("serial", "processes", "ray"),
        help="run independent problems through taskspace.batch (planning and batch suites)",
    )

    p = sub.add_parser("snapshot", help="render a robot at a configuration to PNG/HTML")
    p.add_argument("robot", help="registry name (see `taskspace robots`)")
    p.add_argument(
        "--q",
        help='configuration within the joint limits, e.g. "0,0.1,0,-2,0,2,0.8" (default posture)',
    )
    p.add_argument("--png", help="output PNG file")
    p.add_argument("--html", help="output static HTML file")
    p.add_argument("--geometry", choices=("visual", "collision"), default="visual")
    p.add_argument("--frames", action="store_true", help="draw end-effector triads")
    p.add_argument("--width", type=int, default=640, help="PNG width, 16..4096 [px]")
    p.add_argument("--height", type=int, default=480, help="PNG height, 16..4096 [px]")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``taskspace`` command; returns the exit status."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(message)s"
    )
    if extra and args.command != "demo":
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        if args.command == "info":
            return cmd_info(args)
        if args.command == "robots":
            return cmd_robots(args)
        if args.command == "demo":
            if args.name == "list":
                rows = demo_listing()
                width = max((len(name) for name, _ in rows), default=0)
                print("\n".join(f"{name:<{width}}  {text}".rstrip() for name, text in rows))
                return 0
            return cmd_demo(args, extra)
        if args.command == "bench":
            return cmd_bench(args)
        if args.command == "snapshot":
            return cmd_snapshot(args)
    except CliError as exc:
        print(f"taskspace {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except TaskspaceError as exc:
        print(f"taskspace {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # a file that cannot be read or written (the message names it)
        print(f"taskspace {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        # Ctrl-C: no traceback; the usual status of a command ended by SIGINT. Futures that
        # the headless browser's driver leaves unfinished would be logged at exit: not errors.
        logging.getLogger("asyncio").setLevel(logging.CRITICAL)
        print(f"taskspace {args.command}: interrupted", file=sys.stderr)
        return 130
    parser.error(f"unknown command {args.command}")
    return 2  # pragma: no cover


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    raise SystemExit(main())
