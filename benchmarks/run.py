"""Benchmark runner: ``python -m benchmarks.run [SUITE ...] [--quick] [--save F] [--compare A B]``.

Discovers suites in ``benchmarks/suites/``, runs them, prints one table (median, p95, ratio to
the reference method of the same scene) and optionally saves JSON with the machine and date.
"""

from __future__ import annotations

import os

# Small-matrix timings are steadier with a single BLAS thread on a 2-core machine.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import datetime
import importlib
import json
import platform
import sys
import traceback
from pathlib import Path
from typing import Any

from benchmarks.common import ROOT, Row

SUITES_DIR = Path(__file__).resolve().parent / "suites"


def available_suites() -> list[str]:
    """Names of the suite modules."""
    return sorted(p.stem for p in SUITES_DIR.glob("*.py") if not p.stem.startswith("_"))


def machine_info() -> dict[str, Any]:
    """Where the numbers were measured."""
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def _ratios(rows: list[dict[str, Any]]) -> None:
    index = {(r["suite"], r["scene"], r["method"]): r for r in rows}
    for r in rows:
        ref = index.get((r["suite"], r["scene"], r["ratio_to"])) if r.get("ratio_to") else None
        if ref and r["timing"] and ref["timing"]:
            r["ratio"] = r["timing"]["median_us"] / ref["timing"]["median_us"]
        else:
            r["ratio"] = None


def _fmt_us(x: float | None) -> str:
    if x is None:
        return "-"
    if x >= 1e6:
        return f"{x / 1e6:.2f} s"
    if x >= 1e3:
        return f"{x / 1e3:.2f} ms"
    return f"{x:.1f} us"


def format_table(rows: list[dict[str, Any]]) -> str:
    """Plain-text table of result rows."""
    header = ["suite", "scene", "method", "median", "p95", "ratio", "notes"]
    lines = []
    for r in rows:
        t = r["timing"]
        ratio = f"{r['ratio']:.2f}x {r['ratio_to']}" if r.get("ratio") is not None else ""
        extra = ", ".join(
            f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r["extra"].items()
        )
        notes = "; ".join(x for x in (extra, r["note"]) if x)
        lines.append(
            [
                r["suite"],
                r["scene"],
                r["method"],
                _fmt_us(t["median_us"] if t else None),
                _fmt_us(t["p95_us"] if t else None),
                ratio,
                notes,
            ]
        )
    widths = [max(len(str(x)) for x in col) for col in zip(header, *lines)]
    widths[-1] = 0
    out = ["  ".join(h.ljust(w) for h, w in zip(header, widths))]
    out.append("  ".join("-" * max(w, 5) for w in widths))
    out += ["  ".join(str(x).ljust(w) for x, w in zip(line, widths)) for line in lines]
    return "\n".join(out)


def run_suites(names: list[str], quick: bool) -> list[dict[str, Any]]:
    """Run the named suites; a failing suite becomes an error row, the others still run."""
    rows: list[dict[str, Any]] = []
    for name in names:
        print(f"# running suite {name}{' (quick)' if quick else ''}", file=sys.stderr, flush=True)
        try:
            module = importlib.import_module(f"benchmarks.suites.{name}")
            result: list[Row] = module.run(quick)
            rows += [r.to_dict() for r in result]
        except Exception as exc:
            traceback.print_exc()
            rows.append(Row(name, "-", "-", None, note=f"suite failed: {exc!r}").to_dict())
    _ratios(rows)
    return rows


def compare(a_path: str, b_path: str) -> str:
    """Table of median times of two saved runs and their ratio (b / a)."""
    a = json.loads(Path(a_path).read_text())["rows"]
    b = json.loads(Path(b_path).read_text())["rows"]
    index = {(r["suite"], r["scene"], r["method"]): r for r in a}
    lines = [f"{'suite/scene/method':60s} {'A':>10s} {'B':>10s} {'B/A':>7s}"]
    for r in b:
        key = (r["suite"], r["scene"], r["method"])
        ra = index.get(key)
        if not (ra and ra["timing"] and r["timing"]):
            continue
        ta, tb = ra["timing"]["median_us"], r["timing"]["median_us"]
        lines.append(f"{'/'.join(key):60s} {_fmt_us(ta):>10s} {_fmt_us(tb):>10s} {tb / ta:7.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(prog="benchmarks.run", description=__doc__)
    parser.add_argument(
        "suites", nargs="*", help=f"suites to run (default all): {available_suites()}"
    )
    parser.add_argument("--quick", action="store_true", help="small scenes, few repetitions")
    parser.add_argument("--save", help="write the results as JSON to this file")
    parser.add_argument(
        "--executor",
        choices=["serial", "processes", "ray"],
        help="run the suites' independent problems through taskspace.batch on this backend "
        "(suites that support it: planning, batch); timings are then per worker core",
    )
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two saved runs")
    args = parser.parse_args(argv)
    if args.compare:
        print(compare(*args.compare))
        return 0
    if args.executor:
        os.environ["TASKSPACE_BENCH_EXECUTOR"] = args.executor
    names = args.suites or available_suites()
    unknown = [n for n in names if n not in available_suites()]
    if unknown:
        parser.error(f"unknown suite(s) {unknown}; available: {available_suites()}")
    sys.path.insert(0, str(ROOT))
    rows = run_suites(names, args.quick)
    info = machine_info()
    print(f"# {info['date']} on {info['cpu']} ({info['cores']} cores), Python {info['python']}")
    print(format_table(rows))
    if args.save:
        Path(args.save).parent.mkdir(parents=True, exist_ok=True)
        Path(args.save).write_text(json.dumps({"machine": info, "rows": rows}, indent=1))
        print(f"# saved {args.save}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
