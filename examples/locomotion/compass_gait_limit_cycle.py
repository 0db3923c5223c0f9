"""Compass gait down a 3 degree slope (Tedrake's parameters): a perturbed gait converging to
the limit cycle found by Newton on the Poincare map, in the phase plane of the leg angles."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.locomotion import CompassGait, find_limit_cycle, simulate_step


def main() -> None:
    args = parse(__doc__ or "")
    walker = CompassGait()
    cycle = find_limit_cycle(walker, [-0.2, 1.0, -0.4])
    steps = 8 if fast() else 20

    fig, ax = plt.subplots(figsize=(8, 6))
    x = cycle.post_impact + np.array([0.03, 0.03, -0.15, 0.2])
    for k in range(steps):
        step = simulate_step(walker, x, samples=200)
        if not step.success:
            break
        # the leg that stands in this step: alternate the color per physical leg
        color = plt.cm.viridis(k / steps)
        ax.plot(step.states[:, 0], step.states[:, 2], color=color, lw=0.8)
        ax.plot(step.states[:, 1], step.states[:, 3], color=color, lw=0.8, ls="--")
        x = step.post_impact
    limit = simulate_step(walker, cycle.post_impact, samples=400)
    ax.plot(limit.states[:, 0], limit.states[:, 2], "r", lw=2.5, label="limit cycle, stance leg")
    ax.plot(limit.states[:, 1], limit.states[:, 3], "r--", lw=2.5, label="limit cycle, swing leg")
    ax.plot(
        [limit.states[-1, 0], limit.post_impact[0]],
        [limit.states[-1, 2], limit.post_impact[2]],
        "k:",
        label="impact (legs swap)",
    )
    ax.plot(
        [limit.states[-1, 1], limit.post_impact[1]],
        [limit.states[-1, 3], limit.post_impact[3]],
        "k:",
    )
    mults = ", ".join(f"{abs(m):.3f}" for m in cycle.floquet_multipliers)
    ax.set_title(
        f"compass gait: fixed point {np.array2string(cycle.post_impact, precision=4)}\n"
        f"period {cycle.period:.4f} s, |Floquet multipliers| = {mults}"
    )
    ax.set_xlabel("leg angle [rad]")
    ax.set_ylabel("leg angular velocity [rad/s]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    finish({"compass_gait_limit_cycle": fig}, args.save)


if __name__ == "__main__":
    main()
