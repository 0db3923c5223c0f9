"""Operational-space control of the Panda end-effector, closed form (slides 5:31-5:35).

The end-effector follows ``y''* = Kp (y* - y) - Kd y'`` like a point mass (slide 5:34); a
low-weight posture task (slide 5:35) keeps the null space from drifting. ``--save DIR`` also
writes the motion as ``panda_operational_space.html`` (meshcat animation with the target and
the tcp's path) and ``panda_operational_space_robot.png`` (its last pose).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from _common import fast, finish, parse

from taskspace import features as F
from taskspace.control import OperationalSpaceController, pd_response
from taskspace.dynamics import simulate
from taskspace.model import Robot
from taskspace.tasks import Task
from taskspace.viz.plots_control import plot_tracking_errors


def main() -> None:
    args = parse(__doc__ or "")
    robot = Robot.load("panda")
    T = 1.0 if fast() else 3.0
    ee = F.Position(robot, "panda_hand_tcp")
    y0 = ee.value(robot.state(robot.q_default))
    target = y0 + np.array([0.15, -0.2, 0.1])
    kp, kd = 64.0, 16.0
    tasks = [
        Task(ee, target, kp=kp, kd=kd),
        Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3, kp=10.0),
    ]
    traj = simulate(
        robot, OperationalSpaceController(robot, tasks), (robot.q_default, np.zeros(7)), T, 2e-3
    )
    data = robot.model.createData()
    fid = robot.frame_id("panda_hand_tcp")
    err = []
    for q in traj.q:
        pin.framesForwardKinematics(robot.model, data, q)
        err.append(np.linalg.norm(data.oMf[fid].translation - target))
    ideal = pd_response(traj.t, mass=1.0, kp=kp, kd=kd, q0=float(np.linalg.norm(target - y0)))
    fig = plot_tracking_errors(
        traj.t, {"end-effector error |y - y*| [m]": err, "ideal point mass": np.abs(ideal.q)}
    )
    fig.axes[0].set_title(
        "Panda OSC (closed form); plateau: trade-off with the posture task", fontsize=10
    )
    finish({"panda_operational_space": fig}, args.save)
    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        qs = traj.q[::10]  # every 20 ms
        viewer = Viewer(robot, qs[0])
        viewer.add_target("target", target)
        viewer.add_frame_trace("tcp_path", qs, "panda_hand_tcp")
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "panda_operational_space",
            dt=0.02,
            title="Panda operational-space control to a target 27 cm away",
        )


if __name__ == "__main__":
    main()
