"""Time-optimal time parametrization (TOPP-RA) of a 7-DoF path through waypoints.

A cubic spline (clamped ends) through 10 random waypoints is timed as fast as the Franka
Panda's joint velocity and acceleration limits allow. The figure shows the velocity limit curve
sqrt(xs(s)), the controllable limit of the backward pass and the optimal sdot(s) of the forward
pass, then the joint velocities and accelerations normalized by their limits. A second run adds
a jerk limit (iterative slowdown).

Run: python examples/trajectories/time_parametrization.py [--save DIR_OR_PNG]
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from taskspace.trajopt import TimeParametrizationOptions, cubic_spline, time_parametrize
from taskspace.viz.plots import save_figures as finish
from taskspace.viz.plots_trajectories import plot_time_parametrization

VMAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])  # [rad/s]
AMAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])  # [rad/s^2]


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory or .png file for the figures")
    parser.add_argument("--grid", type=int, default=200, help="number of grid points")
    args = parser.parse_args()
    if args.save or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    return args


def main() -> None:
    args = parse()
    fast = os.environ.get("TASKSPACE_FAST", "") == "1"
    grid = 60 if fast else args.grid
    waypoints = np.random.default_rng(1).uniform(-1.0, 1.0, (10, 7))
    path = cubic_spline(waypoints, boundary="clamped")
    opts = TimeParametrizationOptions(grid_points=grid)
    res = time_parametrize(path, VMAX, AMAX, options=opts)
    print(f"{res.status.value}: duration {res.duration:.3f} s in {res.solve_time * 1e3:.2f} ms")
    print(f"  max |qd|/v_max = {np.max(np.abs(res.qd) / VMAX):.6f}")
    print(f"  max |qdd|/a_max = {np.max(np.abs(res.qdd) / AMAX):.6f}")
    print(
        f"  grid points with an active limit: "
        f"{np.mean((res.active_velocity | res.active_acceleration).any(axis=1)):.0%}"
    )
    jerk = time_parametrize(path, VMAX, AMAX, max_jerk=100.0, options=opts)
    print(
        f"with j_max = 100 rad/s^3: {jerk.status.value}, duration {jerk.duration:.3f} s "
        f"after {jerk.jerk_iterations} slowdown iterations"
    )
    fig1 = plot_time_parametrization(res, VMAX, AMAX)
    fig2 = plot_time_parametrization(jerk, VMAX, AMAX)
    fig2.suptitle(f"with jerk limit 100 rad/s^3: T = {jerk.duration:.3f} s")
    finish({"time_parametrization": fig1, "time_parametrization_jerk": fig2}, args.save)


if __name__ == "__main__":
    main()
