"""G1 standing on both feet, swaying its CoM and holding its hands, under the inverse-dynamics QP.

Slides 5:31-5:35 with contacts: accelerations, contact wrenches and torques from one QP per
control step (two 6-D foot contacts with friction cones and center-of-pressure limits, torque
and joint limits), simulated with rigid contacts (Pinocchio's constraint dynamics). Figures:
CoM against its reference, normal forces and CoP of both feet, torque use. With ``--html``
the motion is written as an animated meshcat scene with the final contact forces.

    python examples/control/g1_inverse_dynamics.py --save out/
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
HANDS = ("left_rubber_hand", "right_rubber_hand")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", help="directory for the figures")
    parser.add_argument("--html", help="write an animated meshcat scene")
    parser.add_argument("--hierarchical", action="store_true", help="strict priorities")
    args = parser.parse_args(argv)
    if args.save or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from taskspace import features as F
    from taskspace.constraints import Contact6D
    from taskspace.control import (
        InverseDynamicsOptions,
        InverseDynamicsQP,
        simulate_with_contacts,
    )
    from taskspace.model import Robot
    from taskspace.tasks import Task

    robot = Robot.load("g1")
    state = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=50.0, priority=0, name="com")
    com.set_target_from_state(state)
    hands = [Task(F.FramePose(robot, h), kp=50.0, weight=0.1, priority=1) for h in HANDS]
    for t in hands:
        t.set_target_from_state(state)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    controller_qp = InverseDynamicsQP(
        robot,
        [com, *hands, posture],
        contacts,
        InverseDynamicsOptions(hierarchical=args.hierarchical),
    )
    c0 = com.target.copy()
    amplitude, frequency = 0.04, 0.5  # [m], [Hz]
    solve_times: list[float] = []
    references: list[np.ndarray] = []

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        reference = c0 + np.array([0.0, amplitude * np.sin(2 * np.pi * frequency * t), 0.0])
        com.set_target(reference)
        references.append(reference)
        state.update(q, v)
        t0 = time.perf_counter()
        result = controller_qp.solve(state)
        solve_times.append(time.perf_counter() - t0)
        if not result.success:
            print(f"t={t:.3f}: {result.status.value} {result.culprits}")
        return result.tau

    duration = 1.0 if os.environ.get("TASKSPACE_FAST") == "1" else 5.0
    rollout = simulate_with_contacts(
        robot, controller, robot.q_default, np.zeros(robot.nv), duration, 0.004, FEET
    )
    print(
        f"{len(solve_times)} control steps, median QP step {np.median(solve_times) * 1e6:.0f} us; "
        f"CoM height varied by {np.ptp(rollout.com[:, 2]) * 1e3:.2f} mm; "
        f"min normal force {min(f[:, 2].min() for f in rollout.forces.values()):.1f} N"
    )

    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    ref = np.array(references)
    axes[0].plot(rollout.t, rollout.com[:, 1] * 100, label="CoM y")
    axes[0].plot(rollout.t, ref[:, 1] * 100, "--", label="reference")
    axes[0].set_ylabel("lateral CoM [cm]")
    axes[0].legend()
    for name, wrench in rollout.forces.items():
        axes[1].plot(rollout.t, wrench[:, 2], label=f"{name} normal force")
        cop_x = -wrench[:, 4] / np.maximum(wrench[:, 2], 1e-9)
        axes[2].plot(rollout.t, cop_x * 100, label=f"{name} CoP x")
    axes[1].set_ylabel("force [N]")
    axes[1].legend()
    axes[2].axhline(10.0, color="k", lw=0.5)
    axes[2].axhline(-10.0, color="k", lw=0.5)
    axes[2].set_ylabel("CoP x [cm] (sole +-10 cm)")
    axes[2].set_xlabel("time [s]")
    axes[2].legend()
    fig.suptitle("G1 inverse-dynamics QP: CoM sway on two feet")
    fig.tight_layout()
    if args.save:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "g1_inverse_dynamics.png", dpi=110)
        print(f"wrote {out / 'g1_inverse_dynamics.png'}")
    elif plt.get_backend().lower() != "agg":
        plt.show()
    if args.html:
        from taskspace.viz import Viewer

        viewer = Viewer(robot, rollout.q[-1])
        final = robot.state(rollout.q[-1])
        for name, wrench in rollout.forces.items():
            M = final.frame_placement(robot.frame_id(name))
            viewer.add_force(f"force_{name}", M.translation, M.rotation @ wrench[-1, :3])
        viewer.add_com(q=rollout.q[-1])
        viewer.play(rollout.q[::5], dt=0.02, autoplay=False)
        viewer.save_html(args.html, title="G1 inverse-dynamics QP")
        print(f"wrote {args.html}")
    return 0


if __name__ == "__main__":
    if (code := main()) != 0:  # no SystemExit on success: the docs gallery runs it in-process
        raise SystemExit(code)
