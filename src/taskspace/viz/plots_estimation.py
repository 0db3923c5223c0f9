"""Matplotlib figures for estimation: beliefs, particles, covariance ellipses, maps, pose graphs.

matplotlib is imported inside the functions (Agg-safe); nothing here is imported by the
estimation algorithms.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace.estimation.covariance import covariance_ellipse


def plot_covariance_ellipse(ax: Any, mean: Any, cov: Any, n_sigma: float = 2.0, **kw: Any) -> Any:
    """Draw the ``n_sigma`` ellipse of a 2-D Gaussian ``N(mean, cov)`` on ``ax``."""
    pts = covariance_ellipse(cov, n_sigma) + np.asarray(mean, dtype=float)[:2]
    return ax.plot(pts[:, 0], pts[:, 1], **kw)


def plot_histogram_beliefs(beliefs: Any, true_cells: Any, doors: Any, steps: Any) -> Any:
    """Stacked bar plots of histogram-filter beliefs at selected steps (slides 7:9-7:15)."""
    import matplotlib.pyplot as plt

    steps = list(steps)
    fig, axes = plt.subplots(len(steps), 1, figsize=(8, 1.6 * len(steps)), sharex=True)
    axes = np.atleast_1d(axes)
    K = np.asarray(beliefs).shape[1]
    for ax, t in zip(axes, steps):
        ax.bar(np.arange(K), beliefs[t], color="tab:blue")
        for d in doors:
            ax.axvspan(d - 0.5, d + 0.5, color="tab:brown", alpha=0.25)
        ax.axvline(true_cells[t], color="tab:red", lw=2)
        ax.set_ylabel(f"t={t}")
    axes[-1].set_xlabel("cell")
    fig.suptitle("Histogram localization (doors shaded, truth in red)")
    fig.tight_layout()
    return fig


def plot_particles(ax: Any, particles: Any, weights: Any | None = None, **kw: Any) -> Any:
    """Scatter particle positions (size proportional to weight)."""
    p = np.asarray(particles)
    s = 2.0 if weights is None else 2.0 + 200.0 * np.asarray(weights) / np.max(weights)
    return ax.scatter(p[:, 0], p[:, 1], s=s, alpha=0.3, **kw)


def plot_pose_graph(ax: Any, poses: Any, edges: Any = (), **kw: Any) -> None:
    """Trajectory of a pose graph plus loop-closure edges (``|i - j| > 1``) in light grey."""
    P = np.asarray(poses)
    for e in edges:
        if abs(e.i - e.j) > 1:
            ax.plot(P[[e.i, e.j], 0], P[[e.i, e.j], 1], color="0.8", lw=0.3, zorder=0)
    ax.plot(P[:, 0], P[:, 1], lw=0.6, **kw)
    ax.set_aspect("equal")
