"""Shared matplotlib helpers: figure styling and save-or-show.

matplotlib is imported inside the functions (Agg-safe, cheap to import). The topic modules
``plots_<topic>.py`` and the examples use these helpers so that every figure honors
``--save DIR_OR_FILE`` and never opens a window under ``MPLBACKEND=Agg``.
"""

from __future__ import annotations

import argparse
import logging
import os
from pathlib import Path
from typing import Any

logger = logging.getLogger(__name__)

DEFAULT_DPI = 110
"""Resolution of saved figures [dots per inch]."""


def use_agg_if_headless(save: str | Path | None = None) -> None:
    """Select the Agg backend when saving to files or when no display is available.

    Call before ``pyplot`` creates a figure. Agg is chosen when ``save`` is given, when
    ``MPLBACKEND=Agg`` is set, or when neither ``DISPLAY`` nor ``WAYLAND_DISPLAY`` exists.
    """
    import matplotlib

    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg" or headless:
        matplotlib.use("Agg")


def style_figure(fig: Any, title: str | None = None, *, grid: bool = True) -> Any:
    """Apply the taskspace figure style: light grids, tight layout, optional suptitle."""
    for ax in fig.get_axes():
        if grid:
            ax.grid(True, alpha=0.3, linewidth=0.6)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def figure_path(save: str | Path, name: str, suffix: str = ".png") -> Path:
    """Output file for a figure: ``save`` itself if it ends in ``suffix``, else ``save/name``.

    Parent directories are created.
    """
    out = Path(save)
    if out.suffix.lower() != suffix:
        out.mkdir(parents=True, exist_ok=True)
        out = out / f"{name}{suffix}"
    else:
        out.parent.mkdir(parents=True, exist_ok=True)
    return out


def save_or_show(
    fig: Any, save: str | Path | None, name: str = "figure", *, dpi: int = DEFAULT_DPI
) -> Path | None:
    """Write ``fig`` to ``save`` (a ``.png`` file or a directory) or show it.

    Without ``save`` the figure is shown, unless the backend is Agg (tests, CI). The figure
    is closed after saving.

    Args:
        fig: a matplotlib figure.
        save: output file or directory, or ``None`` to show.
        name: file stem used when ``save`` is a directory.
        dpi: resolution of the saved image [dots per inch].

    Returns:
        The written file, or ``None`` when shown.
    """
    import matplotlib.pyplot as plt

    if save is not None:
        out = figure_path(save, name)
        fig.savefig(out, dpi=dpi)
        plt.close(fig)
        logger.info("saved figure %s", out)
        return out
    if plt.get_backend().lower() != "agg":
        plt.show()
    return None


def parse_example_args(description: str) -> argparse.Namespace:
    """Arguments shared by the example scripts: ``--save DIR_OR_PNG``; selects Agg if headless."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--save", default=None, help="directory or .png file for the figures")
    args = parser.parse_args()
    use_agg_if_headless(args.save)
    return args


def fast_mode() -> bool:
    """Whether ``TASKSPACE_FAST=1`` asks the examples for short runs (the test suite sets it)."""
    return os.environ.get("TASKSPACE_FAST", "") == "1"


def save_figures(figures: dict[str, Any], save: str | Path | None) -> None:
    """Save each named figure (into ``save``, a directory or a single ``.png``) or show them.

    Each file written is printed (``wrote PATH``): an example says where its figures went.
    """
    import matplotlib.pyplot as plt

    if save is None:
        if plt.get_backend().lower() != "agg":
            plt.show()
        return
    out = Path(save)
    if out.suffix == ".png" and len(figures) == 1:
        out.parent.mkdir(parents=True, exist_ok=True)
        next(iter(figures.values())).savefig(out, dpi=DEFAULT_DPI)
        print(f"wrote {out}", flush=True)
    else:
        base = out.with_suffix("") if out.suffix == ".png" else out
        base.mkdir(parents=True, exist_ok=True)
        for name, fig in figures.items():
            fig.savefig(base / f"{name}.png", dpi=DEFAULT_DPI)
            print(f"wrote {base / f'{name}.png'}", flush=True)
    plt.close("all")
