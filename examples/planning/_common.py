"""Shared helpers of the planning examples (argparse, fast mode, saving figures)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path


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


def finish(fig, save: str | None, name: str) -> None:
    import matplotlib.pyplot as plt

    if save is not None:
        out = Path(save)
        if out.suffix.lower() != ".png":
            out.mkdir(parents=True, exist_ok=True)
            out = out / f"{name}.png"
        else:
            out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=110)
        print(f"saved {out}")
    elif plt.get_backend().lower() != "agg":
        plt.show()
