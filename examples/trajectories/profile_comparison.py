"""Compare the motion profiles of slides 2:32-2:33 on one point-to-point move.

Every profile moves a joint by 1 rad under the same limits (v_max, a_max, j_max) in the shortest
time its shape allows: ramp, sine 1/2 (1 - cos(pi s)), trapezoidal velocity, minimum jerk and
the jerk-limited 7-segment S-curve. A second figure shows a synchronized 3-joint S-curve move in
which the slowest joint sets the duration.

Run: python examples/trajectories/profile_comparison.py [--save DIR_OR_PNG]
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from taskspace.trajopt import plan_motion, synchronize
from taskspace.viz.plots import save_figures as finish
from taskspace.viz.plots_trajectories import plot_motions

PROFILES = ["ramp", "sine", "trapezoidal", "minimum_jerk", "scurve"]


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory or .png file for the figures")
    args = parser.parse_args()
    if args.save or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    return args


def main() -> None:
    args = parse()
    import matplotlib.pyplot as plt

    fast = os.environ.get("TASKSPACE_FAST", "") == "1"
    samples = 200 if fast else 800
    vmax, amax, jmax = 1.0, 2.0, 10.0
    motions = [plan_motion(0.0, 1.0, vmax, amax, jmax, profile=p) for p in PROFILES]
    for name, m in zip(PROFILES, motions, strict=True):
        print(f"{name:>13s}: T = {m.duration:.3f} s, peaks (normalized) = {m.profile.peaks}")
    fig1 = plot_motions(motions, PROFILES, limits=(None, vmax, amax, jmax), samples=samples)
    fig1.suptitle("motion profiles under v_max=1, a_max=2, j_max=10 (1 rad move)")
    fig1.tight_layout()

    q0, q1 = np.array([0.0, 0.5, -1.0]), np.array([1.2, -0.3, 0.4])
    sync = synchronize(q0, q1, [1.0, 0.6, 1.5], [2.0, 2.0, 3.0], [10.0, 10.0, 20.0])
    t = np.linspace(0.0, sync.duration, samples)
    smp = sync.evaluate(t)
    fig2, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for ax, val, name in zip(
        axes, (smp.position, smp.velocity, smp.acceleration), ("q", "qd", "qdd"), strict=True
    ):
        ax.plot(t, val)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig2.suptitle(
        f"synchronized S-curve (straight line in joint space), T = {sync.duration:.2f} s, "
        f"own durations {np.round(sync.joint_durations, 2)}"
    )
    fig2.tight_layout()
    finish({"profile_comparison": fig1, "profile_sync": fig2}, args.save)


if __name__ == "__main__":
    main()
