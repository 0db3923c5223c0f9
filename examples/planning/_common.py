"""Shared helpers of the planning examples (argparse, fast mode, saving figures)."""

from __future__ import annotations

import argparse
import os

from taskspace.viz.plots import save_or_show


def parse_args(description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--save", default=None, help="directory or .png file for the figure(s)")
    args = parser.parse_args()
    if args.save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    return args


def fast() -> bool:
    return os.environ.get("TASKSPACE_FAST", "") not in ("", "0")


def finish(fig, save: str | None, name: str) -> None:  # type: ignore[no-untyped-def]
    out = save_or_show(fig, save, name)
    if out is not None:
        print(f"saved {out}")
