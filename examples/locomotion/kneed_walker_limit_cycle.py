"""Passive walker with knees down a 0.0504 rad slope (Hsu Chen's parameters): the limit cycle
found by Newton on the Poincare map, a perturbed gait converging to it in the phase plane of
the leg angles, the walker's posture through one step (knee strike, then heel strike), and the
torques its knee locks must supply."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.locomotion import KneedWalker, find_kneed_limit_cycle, simulate_kneed_step


def main() -> None:
    args = parse(__doc__ or "")
    walker = KneedWalker()
    cycle = find_kneed_limit_cycle(walker, [-0.1877, 1.1014, -0.0399])
    steps = 6 if fast() else 15

    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(18, 5.5))
    # a perturbed gait (faster stance leg) converging to the cycle
    z = cycle.fixed_point + np.array([0.004, -0.03, 0.02])
    x = np.array([z[0], z[0] - 2 * walker.slope, z[0] - 2 * walker.slope, z[1], z[2], z[2]])
    for k in range(steps):
        step = simulate_kneed_step(walker, x, samples=200)
        if not step.success:
            break
        color = plt.cm.viridis(k / steps)
        for i, ls in ((0, "-"), (1, "--"), (2, ":")):
            ax.plot(step.states[:, i], step.states[:, 3 + i], color=color, lw=0.7, ls=ls)
        x = step.post_impact
    limit = simulate_kneed_step(walker, cycle.post_impact, samples=400)
    labels = ("stance leg", "swing thigh", "swing shank")
    for i, ls in ((0, "-"), (1, "--"), (2, ":")):
        ax.plot(limit.states[:, i], limit.states[:, 3 + i], "r", ls=ls, lw=2.2, label=labels[i])
    ax.plot(*limit.pre_knee_strike[[2, 5]], "ks", label="knee strike (shank)")
    ax.plot(*limit.post_knee_strike[[2, 5]], "ws", mec="k")
    for i in range(2):
        ax.plot(
            [limit.pre_impact[i], limit.post_impact[1 - i]],
            [limit.pre_impact[3 + i], limit.post_impact[4 - i]],
            "k:",
            lw=1,
            label="heel strike (legs swap)" if i == 0 else None,
        )
    mults = ", ".join(f"{abs(m):.3f}" for m in cycle.floquet_multipliers)
    ax.set_title(
        f"fixed point (theta_st, dtheta_st, dtheta_sw) = "
        f"{np.array2string(cycle.fixed_point, precision=4)}\n"
        f"period {cycle.period:.4f} s, |Floquet multipliers| = {mults}",
        fontsize=10,
    )
    ax.set_xlabel("angle from the vertical [rad]")
    ax.set_ylabel("angular velocity [rad/s]")
    ax.legend(fontsize=8)

    # postures through one step of the limit cycle, on the slope
    p = [walker.positions(s[:3]) for s in limit.states[::40]]
    ground = np.array([-0.5, 0.6])
    bx.plot(ground, -ground * np.tan(walker.slope), color="0.5", lw=3)
    for k, pts in enumerate(p):
        color = plt.cm.plasma(k / len(p))
        stance = np.array([[0.0, 0.0], pts["hip"]])
        swing = np.array([pts["hip"], pts["knee"], pts["swing_foot"]])
        bx.plot(*stance.T, color=color, lw=2)
        bx.plot(*swing.T, color=color, lw=1.5, marker="o", ms=3)
    feet = np.array([walker.positions(s[:3])["swing_foot"] for s in limit.states])
    bx.plot(*feet.T, "k--", lw=1, label="swing foot")
    knee_at = walker.positions(limit.post_knee_strike[:3])
    bx.plot(*knee_at["swing_foot"], "ks", label="knee strike")
    # the swing foot's height above the slope where it passes the stance foot (mid-stance)
    clearance = feet[:, 1] + feet[:, 0] * np.tan(walker.slope)
    i = int(np.argmax(feet[:, 0] > 0.0))  # first sample past the stance foot
    mid = np.interp(0.0, feet[i - 1 : i + 1, 0], clearance[i - 1 : i + 1])
    bx.set_title(
        f"one step; swing foot {1000 * mid:.0f} mm above the slope at mid-stance", fontsize=10
    )
    bx.set_aspect("equal")
    bx.set_xlabel("x (downhill) [m]")
    bx.set_ylabel("y [m]")
    bx.legend(fontsize=8)
    # the torques the knee locks must supply (RNEA): > 0 a stop holds, < 0 a latch must
    locked = limit.times > limit.knee_strike_time
    torques = np.array(
        [
            walker.knee_lock_torques(x, swing_knee_locked=bool(k))
            for x, k in zip(limit.states, locked, strict=True)
        ]
    )
    cx.plot(limit.times, torques[:, 0], label="stance knee")
    cx.plot(limit.times[locked], torques[locked, 1], label="swing knee (locked)")
    cx.axhline(0.0, color="k", lw=0.8)
    cx.axvline(limit.knee_strike_time, color="0.5", ls=":", label="knee strike")
    cx.set_title("lock torques: > 0 a stop holds the knee, < 0 it needs a latch", fontsize=10)
    cx.set_xlabel("time in the step [s]")
    cx.set_ylabel("torque [N m]")
    cx.legend(fontsize=8)
    fig.tight_layout()
    finish({"kneed_walker_limit_cycle": fig}, args.save)


if __name__ == "__main__":
    main()
