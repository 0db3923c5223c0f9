"""Minimum-time double integrator: the switching curve found by fitted value iteration.

``x'' = u`` with ``|u| <= 1`` to the origin in minimum time: bang-bang control switching on
``x1 = -x2 |x2| / 2``. The grid policy (colors) is drawn against the analytic parabola.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.optimal_control import (
    DoubleIntegrator,
    FittedValueIterationOptions,
    fitted_value_iteration,
    make_grid,
    min_time,
    min_time_switching_curve,
)


def main() -> None:
    args = parse(__doc__ or "")
    prob = DoubleIntegrator()
    n = 81 if fast() else 161
    ax_ = np.linspace(-2.0, 2.0, n)
    h = ax_[1] - ax_[0]
    grid = make_grid([ax_, ax_])
    res = fitted_value_iteration(
        grid,
        [-1.0, 1.0],
        prob.dynamics,
        prob.unit_cost,
        FittedValueIterationOptions(dt=0.05, substeps=1),
        target=lambda X: np.max(np.abs(X), axis=1) <= 1.01 * h,
    )
    U = res.actions[res.policy, 0].reshape(grid.shape)
    v = np.linspace(-2, 2, 200)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    axes[0].imshow(
        U.T, origin="lower", extent=(-2, 2, -2, 2), cmap="coolwarm", aspect="auto", alpha=0.8
    )
    axes[0].plot(min_time_switching_curve(v), v, "k-", lw=2, label="x1 = -x2|x2|/2")
    axes[0].set_xlim(-2, 2)
    axes[0].set_xlabel("x1 [m]")
    axes[0].set_ylabel("x2 [m/s]")
    axes[0].set_title("policy (red: u = +1, blue: u = -1)")
    axes[0].legend(loc="upper right")
    err = np.abs(res.J - min_time(grid.points())).reshape(grid.shape)
    im = axes[1].imshow(err.T, origin="lower", extent=(-2, 2, -2, 2), aspect="auto")
    fig.colorbar(im, ax=axes[1], label="|J - T*| [s]")
    axes[1].set_title("error of the value against the analytic minimum time")
    axes[1].set_xlabel("x1 [m]")
    fig.tight_layout()
    finish({"double_integrator_min_time": fig}, args.save)


if __name__ == "__main__":
    main()
