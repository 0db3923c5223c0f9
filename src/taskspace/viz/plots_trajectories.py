"""Matplotlib figures for motion profiles and time parametrizations (slides 2:32-2:35).

matplotlib is imported inside the functions so that importing this module never needs a
display; every function returns the figure and never calls ``show``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from taskspace.trajopt.motion_profile import PointToPointMotion
    from taskspace.trajopt.time_parametrization import TimeParametrizationResult

__all__ = ["plot_motions", "plot_time_parametrization"]


def plot_motions(
    motions: Sequence[PointToPointMotion],
    labels: Sequence[str],
    *,
    limits: Sequence[float | None] = (None, None, None, None),
    samples: int = 600,
) -> Figure:
    """Position, velocity, acceleration and jerk of several scalar motions over time.

    Args:
        motions: motions ``x(t) = x0 + MP(t/T) (xT - x0)``.
        labels: one legend entry per motion.
        limits: optional ``(None, v_max, a_max, j_max)`` drawn as dashed lines.
        samples: samples per motion.

    Returns:
        The figure (4 stacked axes, time in [s]).
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    names = ["position", "velocity", "acceleration", "jerk"]
    for motion, label in zip(motions, labels, strict=True):
        t = np.linspace(0.0, motion.duration, samples)
        smp = motion.evaluate(t)
        values = [smp.position, smp.velocity, smp.acceleration, smp.jerk]
        for ax, val in zip(axes, values, strict=True):
            ax.plot(t, val, label=f"{label} (T={motion.duration:.2f} s)")
    for ax, name, lim in zip(axes, names, limits, strict=True):
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
        if lim is not None:
            for sign in (1.0, -1.0):
                ax.axhline(sign * lim, color="k", linestyle="--", linewidth=0.8)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    return fig


def plot_time_parametrization(
    result: TimeParametrizationResult,
    max_velocity: Any = None,
    max_acceleration: Any = None,
) -> Figure:
    """Path velocity ``sdot(s)`` under its limit curves, and the joint trajectories.

    Top: the maximum velocity curve ``sqrt(xs(s))`` (velocity and acceleration limits at each
    grid point), the controllable limit ``sqrt(beta(s))`` from the backward pass and the optimal
    ``sdot(s)`` from the forward pass. Below: joint velocities and accelerations over time,
    normalized by their limits when given (``|.| <= 1``).

    Returns:
        The figure.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(8, 9))
    ax = axes[0]
    cap = np.nanmax(result.controllable_limit) * 1.6 if result.success else 1.0
    ax.plot(result.s, np.minimum(result.velocity_limit, cap), "k-", label="velocity limit curve")
    ax.plot(result.s, result.controllable_limit, "C1--", label="controllable limit (backward)")
    ax.plot(result.s, result.s_dot, "C0-", linewidth=2, label="optimal sdot (forward)")
    ax.set_xlabel("path parameter s [-]")
    ax.set_ylabel("sdot [1/s]")
    ax.set_ylim(0.0, cap)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    vscale = 1.0 if max_velocity is None else np.asarray(max_velocity, dtype=float)
    ascale = 1.0 if max_acceleration is None else np.asarray(max_acceleration, dtype=float)
    axes[1].plot(result.times, result.qd / vscale)
    axes[1].set_ylabel("qd / v_max" if max_velocity is not None else "qd [rad/s]")
    axes[2].plot(result.times, result.qdd / ascale)
    axes[2].set_ylabel("qdd / a_max" if max_acceleration is not None else "qdd [rad/s^2]")
    axes[2].set_xlabel("time [s]")
    for a, given in ((axes[1], max_velocity), (axes[2], max_acceleration)):
        a.grid(True, alpha=0.3)
        if given is not None:
            a.axhline(1.0, color="k", linestyle="--", linewidth=0.8)
            a.axhline(-1.0, color="k", linestyle="--", linewidth=0.8)
    fig.suptitle(f"time-optimal parametrization: T = {result.duration:.3f} s")
    fig.tight_layout()
    return fig
