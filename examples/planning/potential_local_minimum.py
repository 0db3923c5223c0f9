"""Potential field (slides 3:13-3:17): gradient descent gets stuck in a cup-shaped obstacle."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse_args

from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    gradient_descent,
)
from taskspace.viz.plots_planning import plot_path_2d, plot_potential, plot_world


def main() -> None:
    args = parse_args(__doc__)
    cup = Polygon(
        np.array(
            [[4, -2], [6, -2], [6, 2], [4, 2], [4, 1.5], [5.5, 1.5], [5.5, -1.5], [4, -1.5]], float
        )
    )
    world = PolygonWorld((cup, Polygon.regular((2.0, 3.5), 0.8, 12)), (-2, -6, 12, 6))
    field = PotentialField(world, (9.0, 0.0), PotentialFieldOptions(eta=0.5, q_star=1.0))
    fig, ax = plt.subplots(figsize=(8, 5))
    cs = plot_potential(field, ax, resolution=60 if fast() else 160)
    fig.colorbar(cs, ax=ax, label="min(U, 10)")
    plot_world(world, ax)
    for start in ((0.0, 0.0), (0.0, 3.0), (0.0, -4.0)):
        res = gradient_descent(field, start)
        plot_path_2d(res.path, ax, f"start {start}: {res.status.value}", color="w")
        print(
            f"start {start}: {res.status.value} at {np.round(res.path[-1], 3)} "
            f"after {res.iterations} steps"
        )
    ax.plot(*field.goal, "r*", ms=15)
    ax.set_title("U = U_att + U_rep: the cup creates a local minimum")
    finish(fig, args.save, "potential_local_minimum")


if __name__ == "__main__":
    main()
