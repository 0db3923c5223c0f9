"""Bug1 and Bug2 (slides 3:8-3:12) in a polygon world, plus a goal enclosed by a ring."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import finish, parse_args

from taskspace.planning.bug import BugOptions, bug1, bug2
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.viz.plots_planning import plot_path_2d, plot_world


def main() -> None:
    args = parse_args(__doc__)
    c_shape = Polygon(
        np.array([[3, -3], [7, -3], [7, -2], [4, -2], [4, 2], [7, 2], [7, 3], [3, 3]], float)
    )
    world = PolygonWorld((c_shape, Polygon.regular((10, 0.3), 1.0, 10)), (-1, -6, 14, 6))
    ring = PolygonWorld((Polygon.ring((6, 0), (1.5, 1.5), (2.5, 2.5)),), (-1, -6, 14, 6))
    start, goal = (0.0, 0.0), (12.5, 0.0)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    plot_world(world, axes[0])
    for algo, turn, _style in (
        (bug1, "left", "C0-"),
        (bug2, "left", "C1-"),
        (bug2, "right", "C2--"),
    ):
        res = algo(world, start, goal, options=BugOptions(turn=turn))
        plot_path_2d(res.path, axes[0], f"{algo.__name__} ({turn}): {res.length:.1f} m")
        print(f"{algo.__name__:5s} turn={turn:5s} {res.status.value:16s} length {res.length:.2f} m")
    axes[0].plot(*np.array([start, goal]).T, "k:", lw=0.8, label="m-line")
    axes[0].legend(loc="lower left", fontsize=8)
    axes[0].set_title("Bug1 vs Bug2")
    plot_world(ring, axes[1])
    for algo in (bug1, bug2):
        res = algo(ring, start, (6.0, 0.5))
        plot_path_2d(res.path, axes[1], f"{algo.__name__}: {res.status.value}")
        print(f"enclosed goal: {algo.__name__} -> {res.status.value}")
    axes[1].legend(loc="lower left", fontsize=8)
    axes[1].set_title("goal enclosed: failure is reported")
    finish(fig, args.save, "bug_paths")


if __name__ == "__main__":
    main()
