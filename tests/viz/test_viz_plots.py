"""Shared matplotlib helpers: save-or-show and figure paths."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
from PIL import Image

from taskspace.viz.plots import figure_path, save_or_show, style_figure


def test_save_or_show_to_directory_and_file(tmp_path):
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1])
    style_figure(fig, "title")
    out = save_or_show(fig, tmp_path / "figs", "line", dpi=50)
    assert out == tmp_path / "figs" / "line.png"
    assert Image.open(out).size == (200, 150)  # 4 x 3 inches at 50 dpi
    fig2, _ = plt.subplots()
    out2 = save_or_show(fig2, tmp_path / "one.png", "ignored")
    assert out2 == tmp_path / "one.png" and out2.is_file()


def test_save_or_show_without_path_does_not_block_under_agg():
    fig, _ = plt.subplots()
    assert save_or_show(fig, None) is None


def test_figure_path_creates_parents(tmp_path):
    assert figure_path(tmp_path / "a" / "b.png", "x") == tmp_path / "a" / "b.png"
    assert (tmp_path / "a").is_dir()
    assert figure_path(tmp_path / "c", "x") == tmp_path / "c" / "x.png"
