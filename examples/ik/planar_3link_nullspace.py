"""Planar 3-link arm: the end-effector stays put while nullspace motion changes the posture.

Slide 2:29 / 2:59: ``dq = J# (y* - y) + (I - J# J) h``. The 2-D end-effector position is the
first priority (held at its start), the posture ``h`` pulls the arm toward a sequence of
"elbow up" / "elbow down" joint targets at the second priority (a 2-level HierarchicalIK).
The closed-form step with the undamped pseudo-inverse is printed as a check. The figure
draws the arm configurations along the motion and the end-effector drift.

Run: ``python examples/ik/planar_3link_nullspace.py [--save DIR]`` (``TASKSPACE_FAST=1`` for
a short run); ``--save`` also writes the motion as ``planar_3link_nullspace.html`` (meshcat
animation) and ``planar_3link_nullspace_robot.png`` (the arm seen from above at its second
posture target, the end-effector target marked).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration, Position
from taskspace.ik import HierarchicalIK
from taskspace.model import Robot
from taskspace.qp import nullspace_projector, pseudo_inverse
from taskspace.tasks import Task

DT = 0.01  # [s]
FRAMES = ("link1", "link2", "link3", "ee")


def joint_points(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(x, y) of the base, the joints and the end-effector [m]."""
    names = ["joint1", "joint2", "joint3"]
    state = robot.state(q)
    pts = [state.data.oMi[robot.joint_id(n)].translation[:2] for n in names]
    pts.append(state.frame_placement(robot.frame_id("ee")).translation[:2])
    return np.array(pts)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the example (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory for the figure and animation")
    args = parser.parse_args(argv)
    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")
    steps_per_target = 40 if fast else 150

    robot = Robot.load("planar_3link")
    state = robot.state()
    ee = Task(Position(robot, "ee"))
    ee.set_target_from_state(state)
    y_start = ee.target.copy()
    posture = Task(JointConfiguration(robot), robot.q_default, gain=0.1)
    ik = HierarchicalIK(
        robot, [[ee], [posture]], [JointPositionLimits(robot), JointVelocityLimits(robot)]
    )

    # closed-form check at the start (slide 2:29): J (I - J# J) h = 0 for any h
    J = ee.feature.jacobian(state)[:2]
    N = nullspace_projector(J, pseudo_inverse(J))
    h = np.array([1.0, -2.0, 1.0])
    print(f"|J (I - J# J) h| = {np.linalg.norm(J @ N @ h):.1e} (nullspace motion, slide 2:29)")

    q0 = robot.q_default
    targets = [q0 + np.array([0.6, -1.2, 0.9]), q0 + np.array([-0.5, 0.9, -1.2]), q0]
    history = [state.q.copy()]
    drift = []
    for q_target in targets:
        posture.set_target(q_target)
        for _ in range(steps_per_target):
            q, _ = ik.step(state, DT)
            state.update(q)
            history.append(q)
            drift.append(float(np.linalg.norm(ee.error(state)[:2])))
    qs = np.array(history)
    print(
        f"{len(qs) - 1} steps: end-effector drift <= {max(drift):.1e} m, "
        f"posture moved {np.linalg.norm(qs - qs[0], axis=1).max():.2f} rad"
    )

    import matplotlib

    if args.save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    cmap = plt.get_cmap("viridis")
    shown = np.linspace(0, len(qs) - 1, 16).astype(int)
    for j, k in enumerate(shown):
        pts = joint_points(robot, qs[k])
        ax1.plot(pts[:, 0], pts[:, 1], "-o", ms=3, color=cmap(j / (len(shown) - 1)), lw=1.5)
    ax1.plot(*y_start[:2], "r*", ms=14, label="end-effector target")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x [m]")
    ax1.set_ylabel("y [m]")
    ax1.set_title("arm configurations (color: time)")
    ax1.legend(loc="lower left")
    ax2.semilogy(DT * np.arange(1, len(drift) + 1), np.maximum(drift, 1e-16))
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("end-effector error [m]")
    ax2.set_title("priority 1 held while the posture changes")
    ax2.grid(True, which="both", lw=0.3)
    fig.suptitle("Planar 3-link: nullspace motion (slides 2:29, 2:59)")
    fig.tight_layout()
    if args.save is not None:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "planar_3link_nullspace.png", dpi=110)
        print(f"wrote {out / 'planar_3link_nullspace.png'}")
    elif plt.get_backend().lower() != "agg":
        plt.show()

    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        viewer = Viewer(robot, qs[0], floor=False)
        viewer.add_target("ee_target", y_start, scale=0.4)
        viewer.add_frame_trace("ee_path", qs, "ee")
        viewer.frame_scene(direction=(0.0, -0.4, 1.0), margin=1.1)  # from above: a planar arm
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "planar_3link_nullspace",
            dt=DT,
            title="Planar 3-link arm: nullspace motion, end-effector held",
            picture=2 * steps_per_target,  # at the second posture target
        )


if __name__ == "__main__":
    main()
