"""Car parking with a kinodynamic RRT (slides 3:45-3:60), with and without reverse.

With reverse the RRT steers with Reeds-Shepp curves; forward-only it uses Dubins curves. In the
narrow lane a forward-only car cannot turn around (2 r + width > lane width) and fails; in the
wide lane both succeed.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
from _common import fast, finish, parse_args

from taskspace.planning.car import CarModel
from taskspace.planning.kinodynamic_rrt import KinodynamicRRTOptions, kinodynamic_rrt, parking_lot
from taskspace.viz.plots_planning import plot_car_poses, plot_car_tree, plot_path_2d, plot_world


def main() -> None:
    args = parse_args(__doc__)
    model = CarModel()
    iters = 300 if fast() else 3000
    cases = [
        (8.4, "reeds_shepp"),
        (8.4, "dubins"),
        (12.0, "dubins"),
    ]
    fig, axes = plt.subplots(1, len(cases), figsize=(18, 5.5))
    for ax, (lane, steering) in zip(axes, cases):
        world, start, goal = parking_lot(lane_width=lane)
        opts = KinodynamicRRTOptions(steering=steering, max_iterations=iters, seed=0)
        res = kinodynamic_rrt(model, world, start, goal, options=opts)
        plot_world(world, ax)
        plot_car_tree(res, ax)
        plot_car_poses(model, [start, goal], ax, every=1, color="k")
        if res.success:
            plot_path_2d(res.path, ax, color="C3")
            plot_car_poses(model, res.path, ax, every=25)
        mode = "with reverse (RS)" if steering == "reeds_shepp" else "forward only (Dubins)"
        ax.set_title(
            f"lane {lane} m, {mode}: {res.status.value}, {res.n_nodes} nodes, {res.length:.1f} m",
            fontsize=9,
        )
        print(
            f"lane {lane:4.1f} m {steering:12s} {res.status.value:15s} nodes {res.n_nodes:4d} "
            f"length {res.length:6.2f} m  time {res.time_s:.2f} s"
        )
    finish(fig, args.save, "car_parking")


if __name__ == "__main__":
    main()
