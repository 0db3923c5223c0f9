"""Fitted value iteration for the pendulum swing-up: value function and policy heat maps.

Value iteration on a (theta, theta') grid with multilinear interpolation (the HJB equation,
semi-Lagrangian), torque bounded below m g l so the pendulum must swing; a greedy rollout
from hanging down is drawn on top of the value function.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.optimal_control import (
    FittedValueIterationOptions,
    PendulumSwingUp,
    fitted_value_iteration,
    make_grid,
    rk4_step,
)


def main() -> None:
    args = parse(__doc__ or "")
    prob = PendulumSwingUp()
    n = 41 if fast() else 101
    th = np.linspace(0, 2 * np.pi, n + 1)[:-1]
    om = np.linspace(-8, 8, n)
    grid = make_grid([th, om], periods=[2 * np.pi, 0.0])
    dt = 0.05
    res = fitted_value_iteration(
        grid,
        np.linspace(-4, 4, 9),
        prob.dynamics,
        prob.cost,
        FittedValueIterationOptions(dt=dt, substeps=1, discount_rate=0.2),
    )
    x = np.array([[0.0, 0.0]])
    path = [x[0].copy()]
    for _ in range(160):
        x = rk4_step(prob.dynamics, x, res.control(x, prob.dynamics, prob.cost, dt), dt, 4)
        x[0, 0] %= 2 * np.pi
        path.append(x[0].copy())
    path_arr = np.array(path)
    J = res.J.reshape(grid.shape)
    U = res.actions[res.policy, 0].reshape(grid.shape)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    extent = (om[0], om[-1], th[0], th[-1])
    im = axes[0].imshow(J, origin="lower", aspect="auto", extent=extent, cmap="viridis")
    fig.colorbar(im, ax=axes[0], label="cost-to-go J")
    axes[0].plot(path_arr[:, 1], path_arr[:, 0], "w.", ms=2)
    im2 = axes[1].imshow(U, origin="lower", aspect="auto", extent=extent, cmap="coolwarm")
    fig.colorbar(im2, ax=axes[1], label="torque [N m]")
    for ax, title in zip(axes, ("value function", "greedy policy")):
        ax.set_xlabel("theta' [rad/s]")
        ax.set_ylabel("theta [rad] (pi: upright)")
        ax.set_title(title)
    fig.suptitle(
        f"Pendulum swing-up, {n} x {n} grid: {res.dp.iterations} iterations in "
        f"{res.solve_time:.2f} s, median |HJB residual| {np.median(np.abs(res.hjb_residual)):.3f}"
    )
    fig.tight_layout()
    finish({"pendulum_value_function": fig}, args.save)


if __name__ == "__main__":
    main()
