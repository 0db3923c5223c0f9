"""Matplotlib figures for 2-D planning (section 3): worlds, bug paths, potentials, grids, cars.

matplotlib is imported inside each function so that importing this module is cheap and
backend-agnostic (Agg-safe).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace.planning.polygon_world import PolygonWorld


def plot_world(world: PolygonWorld, ax: Any = None) -> Any:
    """Draw the polygon obstacles (holes in white) and the bounds; return the axes."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon as MplPolygon

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5))
    for poly in world.polygons:
        ax.add_patch(MplPolygon(poly.vertices, closed=True, fc="0.6", ec="k"))
        for h in poly.holes:
            ax.add_patch(MplPolygon(h, closed=True, fc="white", ec="k"))
    if world.bounds is not None:
        x0, y0, x1, y1 = world.bounds
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], "k-", lw=0.8)
        ax.set_xlim(x0 - 0.3, x1 + 0.3)
        ax.set_ylim(y0 - 0.3, y1 + 0.3)
    ax.set_aspect("equal")
    return ax


def plot_path_2d(path: Any, ax: Any, label: str = "", **kwargs: Any) -> Any:
    """Draw a 2-D polyline ``(N, >=2)`` with start (circle) and end (star) markers."""
    p = np.asarray(path, dtype=float)
    (line,) = ax.plot(p[:, 0], p[:, 1], label=label, **kwargs)
    ax.plot(p[0, 0], p[0, 1], "o", color=line.get_color())
    ax.plot(p[-1, 0], p[-1, 1], "*", ms=12, color=line.get_color())
    return line


def plot_potential(field: Any, ax: Any, resolution: int = 120, clip: float = 10.0) -> Any:
    """Contour plot of ``min(U, clip)`` of a :class:`PotentialField` over the world bounds."""
    if field.world.bounds is None:
        raise ValueError("the potential plot needs world bounds")
    x0, y0, x1, y1 = field.world.bounds
    xs, ys = np.meshgrid(np.linspace(x0, x1, resolution), np.linspace(y0, y1, resolution))
    u = field.value(np.stack([xs.ravel(), ys.ravel()], 1)).reshape(xs.shape)
    return ax.contourf(xs, ys, np.minimum(u, clip), levels=30, cmap="viridis")


def plot_wavefront(values: Any, ax: Any, path: Any = None, numbers: bool = True) -> Any:
    """Show wavefront labels (slide 3:19) as an image, optionally with numbers and a path."""
    v = np.asarray(values)
    im = ax.imshow(np.where(v == 1, -1, v), origin="lower", cmap="magma_r")
    if numbers and v.size <= 900:
        for (r, c), val in np.ndenumerate(v):
            ax.text(c, r, str(val), ha="center", va="center", fontsize=7)
    if path is not None and len(path):
        p = np.asarray(path)
        ax.plot(p[:, 1], p[:, 0], "c-o", ms=3)
    return im


def plot_car_tree(result: Any, ax: Any, step: float = 0.2) -> None:
    """Draw the edges of a kinodynamic RRT tree (thin grey curves)."""
    for e in result.tree_edges:
        if e is not None:
            s = e.sample(step)
            ax.plot(s[:, 0], s[:, 1], "-", color="0.7", lw=0.5)


def plot_car_poses(model: Any, poses: Any, ax: Any, every: int = 10, color: str = "C3") -> None:
    """Draw the car footprint discs and heading at every ``every``-th pose."""
    from matplotlib.patches import Circle

    p = np.asarray(poses, dtype=float)
    for q in p[::every]:
        for c in model.footprint_centers(q)[0]:
            ax.add_patch(Circle(c, model.footprint_radius, fill=False, ec=color, lw=0.4))
        ax.arrow(q[0], q[1], 0.8 * np.cos(q[2]), 0.8 * np.sin(q[2]), head_width=0.2, color=color)
