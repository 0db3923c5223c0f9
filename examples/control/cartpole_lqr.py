"""LQR balancing of the cart-pole from a 0.2 rad tilt (linearized with ABA derivatives)."""

from __future__ import annotations

import numpy as np
from _common import fast, finish, parse

from taskspace.control import StateFeedbackController, linearize, lqr
from taskspace.dynamics import simulate
from taskspace.model import Robot
from taskspace.viz.plots_control import plot_states


def main() -> None:
    args = parse(__doc__ or "")
    robot = Robot.load("cartpole")
    system = linearize(robot, np.zeros(2), actuated=["slider"])  # the hinge is passive
    design = lqr(system.A, system.B, np.diag([1.0, 10.0, 1.0, 1.0]), 0.1)
    ctrl = StateFeedbackController(robot, system, design.K)
    T = 3.0 if fast() else 8.0
    traj = simulate(robot, ctrl, (np.array([0.0, 0.2]), np.zeros(2)), T, 2e-3)
    states = np.hstack([traj.q, traj.v])
    fig = plot_states(
        traj.t,
        states,
        ["x [m]", "theta [rad]", "x' [m/s]", "theta' [rad/s]"],
        title=f"cart-pole LQR, K = {np.array2string(design.K[0], precision=2)}",
        inputs=traj.tau[:, 0],
    )
    finish({"cartpole_lqr": fig}, args.save)


if __name__ == "__main__":
    main()
