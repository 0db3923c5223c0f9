"""Wavefront planner (slides 3:18-3:25): labels with 4- and 8-connectivity, and the descent."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import finish, parse_args

from taskspace.planning.grid import OccupancyGrid, grid_search, wavefront, wavefront_path
from taskspace.viz.plots_planning import plot_wavefront


def main() -> None:
    args = parse_args(__doc__)
    occ = np.zeros((14, 18), bool)
    occ[3:11, 6] = True
    occ[3, 6:13] = True
    occ[10, 9:16] = True
    occ[6:10, 12] = True
    grid = OccupancyGrid(occ)
    goal, start = (12, 16), (1, 1)
    fig, axes = plt.subplots(1, 2, figsize=(14, 6))
    for ax, conn in zip(axes, (4, 8)):
        wf = wavefront(grid, goal, connectivity=conn)
        path = wavefront_path(wf, start)
        astar = grid_search(grid, start, goal)
        plot_wavefront(wf.values, ax, path.path)
        ax.set_title(
            f"{conn}-connectivity: {int(path.cost)} moves (A* 8-conn cost {astar.cost:.2f})"
        )
        print(f"{conn}-connectivity: {wf.waves} waves, path of {int(path.cost)} moves")
    finish(fig, args.save, "wavefront_numbers")


if __name__ == "__main__":
    main()
