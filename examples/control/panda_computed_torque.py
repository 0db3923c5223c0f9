"""Computed-torque tracking on the Panda vs independent-joint PD (slides 5:27-5:30)."""

from __future__ import annotations

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
    times = None
    for label, ctrl in controllers.items():
        traj = simulate(robot, ctrl, x0, T, 1e-3)
        times = traj.t
        errors[label] = tracking_error(traj.t, traj.q, ref)
    fig = plot_tracking_errors(times, errors)
    fig.axes[0].set_ylabel("max joint error [rad]")
    fig.axes[0].set_title("Panda: tracking a sinusoidal joint reference")
    finish({"panda_computed_torque": fig}, args.save)


if __name__ == "__main__":
    main()
