"""LQR balancing of the cart-pole from a 0.2 rad tilt (linearized with ABA derivatives).

The figure shows the states and the cart force; ``--save DIR`` also writes the motion as
``cartpole_lqr.html`` (meshcat animation) and ``cartpole_lqr_robot.png`` (the cart-pole
at its initial 0.2 rad tilt, the problem the controller solves).
"""

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
    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        qs = traj.q[::10]  # every 20 ms
        viewer = Viewer(robot, qs[0])
        # from the side (the pole swings in x-z), close to the cart: the 6 m rail is not the story
        middle = np.array([0.5 * (qs[:, 0].min() + qs[:, 0].max()), 0.0, 0.2])
        viewer.set_camera(middle + np.array([0.0, -1.2, 0.3]), middle)
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "cartpole_lqr",
            dt=0.02,
            title="Cart-pole LQR balancing from a 0.2 rad tilt",
            picture=0,
        )


if __name__ == "__main__":
    main()
