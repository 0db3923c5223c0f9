"""ZMP preview control (Kajita 2003) on straight and curved footstep plans: ZMP, CoM and the
support polygons seen from above, and the ZMP MPC keeping the ZMP inside them after a push."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse
from matplotlib.patches import Polygon

from taskspace.locomotion import (
    CartTable,
    PreviewController,
    SoleSize,
    SupportPolygon,
    ZmpMpc,
    arc_walk,
    preview_walking_pattern,
    straight_walk,
)


def _top_view(ax, pattern, sole, title):
    plan, traj = pattern.plan, pattern.trajectory
    for foot in (*plan.initial, *plan.steps):
        color = "tab:blue" if foot.side == "left" else "tab:red"
        ax.add_patch(
            Polygon(foot.sole_corners(sole.length, sole.width), fill=False, ec=color, lw=1)
        )
    ax.plot(*traj.zmp_reference.T, "k--", lw=1, label="ZMP reference")
    ax.plot(*traj.zmp.T, "g", lw=1.2, label="ZMP")
    ax.plot(*traj.com.T, "m", lw=2, label="CoM")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{title}: RMS ZMP error {1000 * traj.rms_zmp_error:.2f} mm")
    ax.legend(loc="best", fontsize=8)


def main() -> None:
    args = parse(__doc__ or "")
    n = 6 if fast() else 10
    sole = SoleSize(length=0.2, width=0.1)
    model = CartTable(com_height=0.8, dt=0.005)
    straight = preview_walking_pattern(straight_walk(n, step_length=0.25), model)
    curved = preview_walking_pattern(arc_walk(n, radius=1.2, angle=1.2), model)

    fig_top, axes = plt.subplots(1, 2, figsize=(13, 5))
    _top_view(axes[0], straight, sole, f"straight, {n} steps")
    _top_view(axes[1], curved, sole, f"arc R = 1.2 m, {n} steps")
    fig_top.tight_layout()

    traj = straight.trajectory
    fig_t, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for k, name in enumerate(("x", "y")):
        ax[k].plot(traj.times, traj.zmp_reference[:, k], "k--", lw=1, label="ZMP ref")
        ax[k].plot(traj.times, traj.zmp[:, k], "g", label="ZMP")
        ax[k].plot(traj.times, traj.com[:, k], "m", label="CoM")
        ax[k].set_ylabel(f"{name} [m]")
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel("t [s]")
    ax[0].set_title("preview control: the CoM moves before the ZMP reference (preview 1.6 s)")
    fig_t.tight_layout()

    # a push while standing: preview control leaves the feet, the MPC does not
    mpc_model = CartTable(com_height=0.8, dt=0.05)
    T = 40
    feet = SupportPolygon.from_points([[-0.1, -0.15], [0.1, -0.15], [0.1, 0.15], [-0.1, 0.15]])
    x0 = np.zeros((3, 2))
    x0[1, 0] = 0.25
    mpc = ZmpMpc(mpc_model).simulate(np.zeros((T, 2)), [feet] * T, x0)
    preview = PreviewController(mpc_model).simulate(np.zeros((T, 2)), x0)
    fig_p, axp = plt.subplots(figsize=(8, 4))
    axp.axhline(0.1, color="k", lw=1, ls=":", label="front edge of the feet")
    axp.plot(preview.times, preview.zmp[:, 0], "g--", label="ZMP, preview control")
    axp.plot(mpc.trajectory.times, mpc.trajectory.zmp[:, 0], "g", label="ZMP, MPC")
    axp.plot(mpc.trajectory.times, mpc.trajectory.com[:, 0], "m", label="CoM, MPC")
    axp.set_xlabel("t [s]")
    axp.set_ylabel("x [m]")
    axp.set_title("push of 0.25 m/s: ZMP MPC with support-polygon constraints")
    axp.legend(fontsize=8)
    fig_p.tight_layout()
    finish({"lipm_top_view": fig_top, "lipm_time": fig_t, "lipm_mpc_push": fig_p}, args.save)


if __name__ == "__main__":
    main()
