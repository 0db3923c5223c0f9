"""Matplotlib figures for control: point-mass responses, tracking errors, state trajectories.

matplotlib is imported inside the functions (Agg-safe); nothing here is imported by the
control or dynamics algorithms.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


def plot_point_mass_responses(responses: Mapping[str, Any], target: float = 0.0) -> Any:
    """Overlay closed-form PD responses ``q(t)`` of several damping regimes (slide 5:13).

    Args:
        responses: label -> :class:`~taskspace.control.point_mass.PointMassResponse`.
        target: ``q*`` drawn as a dashed line.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for label, resp in responses.items():
        ax.plot(resp.t, resp.q, label=f"{label} (xi={resp.damping_ratio:.2f})")
    ax.axhline(target, color="k", ls="--", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("q [m]")
    ax.set_title("1-D point mass under PD control")
    ax.legend()
    fig.tight_layout()
    return fig


def plot_tracking_errors(times: Any, errors: Mapping[str, Any], *, log: bool = True) -> Any:
    """Tracking error norms over time, one line per controller.

    Args:
        times: (N,) [s].
        errors: label -> (N,) error [rad or m].
        log: logarithmic y axis.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for label, err in errors.items():
        ax.plot(times, np.maximum(np.asarray(err, dtype=float), 1e-12), label=label)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("tracking error")
    ax.legend()
    fig.tight_layout()
    return fig


def plot_states(
    times: Any, states: Any, labels: Sequence[str], *, title: str = "", inputs: Any = None
) -> Any:
    """State trajectories (one subplot per state, plus the input if given)."""
    import matplotlib.pyplot as plt

    X = np.asarray(states, dtype=float)
    rows = X.shape[1] + (0 if inputs is None else 1)
    fig, axes = plt.subplots(rows, 1, figsize=(7, 1.6 * rows), sharex=True)
    axes = np.atleast_1d(axes)
    for i, label in enumerate(labels):
        axes[i].plot(times, X[:, i])
        axes[i].set_ylabel(label)
        axes[i].axhline(0.0, color="k", lw=0.5)
    if inputs is not None:
        axes[-1].plot(times, inputs, color="tab:red")
        axes[-1].set_ylabel("u")
    axes[-1].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
