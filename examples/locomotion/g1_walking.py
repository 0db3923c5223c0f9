"""G1 walks: LIPM preview-control CoM and swing-foot trajectories tracked by one
inverse-dynamics QP whose contacts change at run time (a foot removed with a force ramp before
it lifts, added back at touchdown), simulated with rigid contacts switched at lift-off and
touchdown.

Figures: the footsteps (CoP rectangles), the measured ZMP and the CoM seen from above; the
ZMP's distance to the support polygon and the normal forces over time. With ``--save`` the
walk is also written as an animated meshcat scene (HTML) and a PNG snapshot of it.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse
from matplotlib.patches import Polygon

from taskspace.locomotion import StepTiming, WalkingOptions, plan_from_robot, walk
from taskspace.model import Robot


def main() -> None:
    args = parse(__doc__ or "")
    robot = Robot.load("g1")
    timing = StepTiming(
        single_support=0.6,
        double_support=0.2,
        initial_double_support=1.0,
        final_double_support=1.0,
        weight_shift=0.4,
    )
    n_steps, yaw = (3, 0.0) if fast() else (10, 0.08)
    plan = plan_from_robot(
        robot, robot.q_default, n_steps, step_length=0.1, yaw_per_step=yaw, timing=timing
    )
    opts = WalkingOptions()
    res = walk(robot, plan, opts)
    print(
        f"{len(plan.steps)} steps in {res.times[-1]:.1f} s simulated: success={res.success} "
        f"{res.message}; min ZMP margin {1000 * res.zmp_margin.min():.2f} mm, worst cone "
        f"violation {res.cone_violation:.2g} N, {res.solves['contact_changes']} contact changes "
        f"on one controller, median QP step {1e6 * np.median(res.control_times):.0f} us"
    )

    fig_top, ax = plt.subplots(figsize=(9, 6))
    hl, hw = opts.sole_half_length, opts.sole_half_width
    for foot in (*plan.initial, *plan.steps):
        ax.add_patch(
            Polygon(
                foot.sole_corners(2 * hl, 2 * hw),
                fill=False,
                ec="tab:blue" if foot.side == "left" else "tab:red",
            )
        )
    ax.plot(*res.zmp.T, "g", lw=0.8, label="measured ZMP (contact wrenches)")
    ax.plot(*res.com_reference[:, :2].T, "k--", lw=1, label="CoM reference (LIPM)")
    ax.plot(*res.com[:, :2].T, "m", lw=2, label="CoM")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("G1 walking: footsteps (CoP rectangles), ZMP and CoM")
    ax.legend(fontsize=8)
    fig_top.tight_layout()

    fig_t, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    axes[0].plot(res.times, 1000 * res.zmp_margin)
    axes[0].axhline(0, color="k", lw=0.8)
    axes[0].set_ylabel("ZMP margin [mm]")
    axes[1].plot(res.times, res.com[:, 2] - res.com_reference[:, 2], label="CoM height error")
    axes[1].set_ylabel("[m]")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize=8)
    fig_t.tight_layout()
    finish({"g1_walking_top": fig_top, "g1_walking_time": fig_t}, args.save)

    if args.save:
        from taskspace.viz import Viewer

        out = Path(args.save)
        viewer = Viewer(robot, res.q[-1])
        viewer.add_path("com", res.com[::10], color=0xD62728)
        viewer.play(res.q[::10], dt=10 * opts.dt, autoplay=False)
        c = res.com[-1]
        viewer.set_camera(c + np.array([1.2, -1.6, 0.6]), c - np.array([0.2, 0.0, 0.3]))
        html = viewer.save_html(out / "g1_walking.html", title="G1 walking")
        print(f"wrote {html}")
        try:
            print("rendering the PNG snapshot in headless Chromium (a few seconds)...", flush=True)
            viewer.snapshot(out / "g1_walking_snapshot.png")
            print(f"wrote {out / 'g1_walking_snapshot.png'}")
        except Exception as exc:  # no headless Chromium on this machine
            print(f"no snapshot: {exc}")


if __name__ == "__main__":
    main()
