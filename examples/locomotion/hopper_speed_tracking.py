"""Raibert's planar one-legged hopper: hopping height, forward speed and body attitude
controlled separately; the forward speed follows a staircase of commands up to 2 m/s."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.locomotion import HopperParameters, RaibertOptions, simulate_hopper


def main() -> None:
    args = parse(__doc__ or "")
    levels = [0.0, 0.5, 1.0, 2.0, 1.0] if not fast() else [0.0, 1.0, 2.0]
    hold = 12.0

    def command(t: float) -> float:
        # ramps of 0.25 m/s^2 between the levels
        k = min(int(t // hold), len(levels) - 1)
        prev = levels[k - 1] if k else levels[0]
        target = levels[k]
        ramp = prev + np.sign(target - prev) * 0.25 * (t - k * hold)
        return float(min(ramp, target) if target >= prev else max(ramp, target))

    res = simulate_hopper(
        HopperParameters(),
        RaibertOptions(),
        command,
        hold * len(levels),
        initial_state=[0.0, 0.7, 0.15, 0.0, 0.0, 0.0],
    )
    t = res.times
    fig, ax = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    ax[0].plot(t, [command(s) for s in t], "k--", label="command")
    ax[0].plot(res.apex_times, res.apex_speeds, "o-", ms=3, label="speed at apex")
    ax[0].set_ylabel("forward speed [m/s]")
    ax[0].legend(fontsize=8)
    ax[0].set_title("Raibert hopper" + ("" if res.success else f" (stopped: {res.message})"))
    ax[1].plot(t, res.states[:, 1], lw=0.8)
    ax[1].axhline(0.7, color="k", ls=":", label="desired apex")
    ax[1].set_ylabel("hip height [m]")
    ax[1].legend(fontsize=8)
    ax[2].plot(t, res.states[:, 2], lw=0.8)
    ax[2].set_ylabel("body pitch [rad]")
    ax[2].set_xlabel("t [s]")
    fig.tight_layout()
    finish({"hopper_speed_tracking": fig}, args.save)


if __name__ == "__main__":
    main()
