"""toppra peer for the ``trajectories`` suite: TOPP-RA on a waypoint path.

Usage: ``python toppra_trajectories.py SCENE.json``. The JSON holds ``waypoints`` (m, n),
``max_velocity`` (n,), ``max_acceleration`` (n,), ``grid_points``, ``bc_type``, ``warmup`` and
``repeat``. The same problem is solved ``repeat`` times, each call from the waypoints: cubic
spline (scipy, through toppra's ``SplineInterpolator``), constraints, TOPP-RA with the given
gridpoints, and the output trajectory (``ParametrizeConstAccel``: ``dt = 2 ds / (sd_k + sd_k+1)``,
the same time recovery taskspace uses). Prints one JSON line.
"""

from __future__ import annotations

import json
import logging
import sys
import time
from importlib.metadata import version

import numpy as np
import toppra as ta
import toppra.algorithm as algo
import toppra.constraint as constraint


def solve(scene: dict) -> float:
    w = np.asarray(scene["waypoints"], dtype=float)
    vmax = np.asarray(scene["max_velocity"], dtype=float)
    amax = np.asarray(scene["max_acceleration"], dtype=float)
    ss = np.linspace(0.0, 1.0, w.shape[0])
    path = ta.SplineInterpolator(ss, w, bc_type=scene["bc_type"])
    pc_vel = constraint.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1))
    pc_acc = constraint.JointAccelerationConstraint(
        np.stack([-amax, amax], axis=1),
        discretization_scheme=constraint.DiscretizationType.Interpolation,
    )
    grid = np.linspace(0.0, 1.0, int(scene["grid_points"]))
    inst = algo.TOPPRA(
        [pc_vel, pc_acc],
        path,
        gridpoints=grid,
        solver_wrapper="seidel",
        parametrizer="ParametrizeConstAccel",
    )
    traj = inst.compute_trajectory(0.0, 0.0)
    if traj is None:
        return float("nan")
    return float(traj.duration)


def main() -> None:
    logging.disable(logging.WARNING)
    with open(sys.argv[1]) as f:
        scene = json.load(f)
    duration = solve(scene)
    for _ in range(int(scene.get("warmup", 5))):
        solve(scene)
    samples = []
    for _ in range(int(scene.get("repeat", 50))):
        t0 = time.perf_counter()
        solve(scene)
        samples.append(time.perf_counter() - t0)
    a = np.asarray(samples) * 1e6
    print(
        json.dumps(
            {
                "peer": "toppra",
                "version": version("toppra"),
                "duration": duration,
                "median_us": float(np.median(a)),
                "p95_us": float(np.percentile(a, 95)),
                "p99_us": float(np.percentile(a, 99)),
                "mean_us": float(np.mean(a)),
                "n": int(a.size),
            }
        )
    )


if __name__ == "__main__":
    main()
