"""Computed-torque tracking on the Panda vs independent-joint PD (slides 5:27-5:30).

The figure shows the joint tracking errors of the three controllers; ``--save DIR`` also
writes the computed-torque motion as ``panda_computed_torque.html`` (meshcat animation with
the tcp's path) and ``panda_computed_torque_robot.png`` (its last pose).
"""

from __future__ import annotations

import numpy as np
from _common import fast, finish, parse

from taskspace.control import (
    ComputedTorqueController,
    JointPDController,
    SinusoidalReference,
    tracking_error,
)
from taskspace.dynamics import simulate
from taskspace.model import Robot
from taskspace.viz.plots_control import plot_tracking_errors

KP = [600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0]  # Franka's joint impedance [N m/rad]
KD = [50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0]


def main() -> None:
    args = parse(__doc__ or "")
    robot = Robot.load("panda")
    T = 1.0 if fast() else 5.0
    ref = SinusoidalReference(robot.q_default, 0.3, [0.5, 0.4, 0.3, 0.5, 0.6, 0.4, 0.5])
    r0 = ref(0.0)
    x0 = (r0.q + 0.05, r0.v)  # start 0.05 rad off the reference
    controllers = {
        "computed torque (lambda = 50 ms, xi = 1)": ComputedTorqueController.from_wavelength(
            robot, ref, 0.05
        ),
        "joint PD + gravity compensation": JointPDController(robot, ref, KP, KD),
        "joint PD": JointPDController(robot, ref, KP, KD, gravity_compensation=False),
    }
    errors = {}
    trajectories = {}
    for label, ctrl in controllers.items():
        traj = simulate(robot, ctrl, x0, T, 1e-3)
        trajectories[label] = traj
        errors[label] = tracking_error(traj.t, traj.q, ref, robot=robot)
        print(f"{label}: max joint error {np.max(errors[label]):.4f} rad")
    times = traj.t
    fig = plot_tracking_errors(times, errors)
    fig.axes[0].set_ylabel("max joint error [rad]")
    fig.axes[0].set_title("Panda: tracking a sinusoidal joint reference")
    finish({"panda_computed_torque": fig}, args.save)
    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        qs = next(iter(trajectories.values())).q[::20]  # computed torque, every 20 ms
        viewer = Viewer(robot, qs[0])
        viewer.add_frame_trace("tcp_path", qs, "panda_hand_tcp")
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "panda_computed_torque",
            dt=0.02,
            title="Panda: computed-torque tracking of a sinusoidal joint reference",
        )


if __name__ == "__main__":
    main()
