"""1-D hallway localization with a histogram (Bayes) filter, slides 7:9-7:17.

Run: python examples/estimation/hallway_histogram_localization.py [--save DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import fast, finish, parse

from taskspace.estimation.histogram_filter import HallwayWorld, HistogramFilter
from taskspace.viz.plots_estimation import plot_histogram_beliefs


def main() -> None:
    args = parse(__doc__ or "")
    world = HallwayWorld(motion_kernel=(0.05, 0.9, 0.05), p_detect=0.9, p_false_alarm=0.05)
    T = 20 if fast() else 60
    rng = np.random.default_rng(0)
    cells, seen = world.simulate(10, [1] * T, rng)
    res = HistogramFilter(np.ones(world.num_cells)).run(
        [world.transition(1)] * T, [world.likelihood(y) for y in seen]
    )
    dr = HistogramFilter(np.eye(world.num_cells)[10]).run([world.transition(1)] * T, [None] * T)
    steps = np.linspace(0, T - 1, 5).astype(int)
    figs = {
        "hallway_filter": plot_histogram_beliefs(res.beliefs, cells, world.doors, steps),
        "hallway_dead_reckoning": plot_histogram_beliefs(dr.beliefs, cells, world.doors, steps),
    }
    near = res.beliefs[-1][(cells[-1] + np.arange(-2, 3)) % 60].sum()
    print(f"final belief within 2 cells of the truth: {near:.2f}")
    finish(figs, args.save)


if __name__ == "__main__":
    main()
