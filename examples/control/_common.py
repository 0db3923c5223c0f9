"""Shared helpers of the control examples (argument parsing, figure saving)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any


def parse(description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--save", default=None, help="directory or .png file for the figures")
    args = parser.parse_args()
    if args.save or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    return args


def fast() -> bool:
    return os.environ.get("TASKSPACE_FAST", "") == "1"


def finish(figs: dict[str, Any], save: str | None) -> None:
    import matplotlib.pyplot as plt

    if save:
        out = Path(save)
        if out.suffix == ".png" and len(figs) == 1:
            out.parent.mkdir(parents=True, exist_ok=True)
            next(iter(figs.values())).savefig(out, dpi=110)
        else:
            base = out.with_suffix("") if out.suffix == ".png" else out
            base.mkdir(parents=True, exist_ok=True)
            for name, fig in figs.items():
                fig.savefig(base / f"{name}.png", dpi=110)
        plt.close("all")
    elif plt.get_backend().lower() != "agg":
        plt.show()
