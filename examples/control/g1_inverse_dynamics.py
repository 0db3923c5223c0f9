"""G1 standing on both feet, swaying its CoM and holding its hands, under the inverse-dynamics QP.

Slides 5:31-5:35 with contacts: accelerations, contact wrenches and torques from one QP per
control step (two 6-D foot contacts with friction cones and center-of-pressure limits, torque
and joint limits), simulated with rigid contacts (Pinocchio's constraint dynamics). Figures:
CoM against its reference, normal forces and CoP of both feet, torque use. ``--save DIR``
also writes the motion as ``g1_inverse_dynamics.html`` (meshcat animation) and
``g1_inverse_dynamics_robot.png`` (the robot at the largest sway, with its contact forces and
CoM); ``--html FILE`` writes the same animation to ``FILE``.

The CoM follows ``y* = 4 cm sin(2 pi 0.5 Hz t)`` (the amplitude fades in over the first
second) with its velocity and acceleration as feedforward (:meth:`Task.set_reference`):
``c''* = y''* + kd (y'* - c') + kp (y* - c)``. Without them the CoM task is a low-pass
filter ``kp / (s^2 + kd s + kp)`` (kp = 50, kd = 14.1): at 0.5 Hz it passes 0.83 of the
amplitude 48 degrees late (3.3 cm of 4, 3.0 cm tracking error); and a posture task of weight
1e-2 pulling to the straight stance (CoM centered) took that down to the 2.6 cm an earlier
version of this example showed. With the feedforward and the posture at weight 1e-4 the CoM
sways 3.96 cm, 0.4 mm off its reference (``--hierarchical``: 3.99 cm, 0.2 mm).

At each extreme the lighter foot's CoP reaches the toe edge of its sole (10 cm): the CoM is
4.6 cm ahead of the ankles, and both feet keep about the same pitch moment (7-9 N m, the
force regularization shares it) while their normal loads swing between 70 and 250 N, so the
lighter foot's ``-tau_y / f_z`` grows until the QP's CoP constraint holds it at the edge.

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
AMPLITUDE = 0.04  # lateral CoM sway [m]
FREQUENCY = 0.5  # [Hz]
RAMP = 1.0  # the amplitude fades in over this time [s] (a sine starting at full speed jolts)
POSTURE_WEIGHT = 1e-4  # low: the posture (CoM centered) hardly pulls against the sway


def sway(t: float) -> tuple[float, float, float]:
    """Lateral CoM offset [m], velocity [m/s] and acceleration [m/s^2] of the reference.

    ``y = A e(t) sin(w t)`` with the quintic fade-in ``e = 10 s^3 - 15 s^4 + 6 s^5``,
    ``s = min(t / RAMP, 1)``: position, velocity and acceleration start at zero.
    """
    w = 2.0 * np.pi * FREQUENCY
    s = min(t / RAMP, 1.0)
    e = s**3 * (10.0 - 15.0 * s + 6.0 * s**2)
    de = 30.0 * s**2 * (1.0 - s) ** 2 / RAMP
    dde = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / RAMP**2
    sn, cs = np.sin(w * t), np.cos(w * t)
    return (
        AMPLITUDE * e * sn,
        AMPLITUDE * (de * sn + e * w * cs),
        AMPLITUDE * (dde * sn + 2.0 * de * w * cs - e * w * w * sn),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", help="directory for the figures, animation and robot picture")
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
    posture = Task(
        F.JointConfiguration(robot), robot.q_default, weight=POSTURE_WEIGHT, kp=30.0, priority=2
    )
    controller_qp = InverseDynamicsQP(
        robot,
        [com, *hands, posture],
        contacts,
        InverseDynamicsOptions(hierarchical=args.hierarchical),
    )
    c0 = com.target.copy()
    lateral = np.array([0.0, 1.0, 0.0])
    solve_times: list[float] = []

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        y, dy, ddy = sway(t)
        com.set_target(c0 + y * lateral)
        com.set_reference(dy * lateral, ddy * lateral)
        state.update(q, v)
        t0 = time.perf_counter()
        result = controller_qp.solve(state)
        solve_times.append(time.perf_counter() - t0)
        if not result.success:
            print(f"t={t:.3f}: {result.status.value} {result.culprits}")
        return result.tau

    duration = 2.0 if os.environ.get("TASKSPACE_FAST") == "1" else 5.0
    rollout = simulate_with_contacts(
        robot, controller, robot.q_default, np.zeros(robot.nv), duration, 0.004, FEET
    )
    ref = c0[1] + np.array([sway(t)[0] for t in rollout.t])
    after = rollout.t >= RAMP
    swayed = np.abs(rollout.com[after, 1] - c0[1]).max()
    error = np.abs(rollout.com[after, 1] - ref[after]).max()
    print(
        f"{len(solve_times)} control steps, median QP step {np.median(solve_times) * 1e6:.0f} us; "
        f"CoM height varied by {np.ptp(rollout.com[:, 2]) * 1e3:.2f} mm; "
        f"min normal force {min(f[:, 2].min() for f in rollout.forces.values()):.1f} N"
    )
    print(
        f"lateral CoM sway after the {RAMP:.0f} s fade-in: up to {swayed * 100:.2f} cm of "
        f"{AMPLITUDE * 100:.0f} cm, max tracking error {error * 1000:.1f} mm"
    )

    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    axes[0].plot(rollout.t, rollout.com[:, 1] * 100, label="CoM y")
    axes[0].plot(rollout.t, ref * 100, "--", label="reference")
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
    if args.html or args.save:
        from taskspace.viz import Viewer, save_robot_motion

        every = 5  # 20 ms between animation frames
        qs = rollout.q[::every]
        peak = int(np.argmax(rollout.com[::every, 1]))  # the picture: the largest sway
        viewer = Viewer(robot, qs[peak])
        shown = robot.state(qs[peak])
        for name, wrench in rollout.forces.items():
            M = shown.frame_placement(robot.frame_id(name))
            viewer.add_force(f"force_{name}", M.translation, M.rotation @ wrench[::every][peak, :3])
        viewer.add_com(q=qs[peak])
        viewer.frame_scene(direction=(1.0, 0.15, 0.25))  # from the front: the sway is lateral
        title = f"G1 inverse-dynamics QP (forces and CoM at t = {rollout.t[::every][peak]:.2f} s)"
        save_robot_motion(
            viewer, qs, args.save, "g1_inverse_dynamics", dt=0.02, title=title, picture=peak
        )
        if args.html:
            viewer.save_html(args.html, title=title)
            print(f"wrote {args.html}")
    return 0


if __name__ == "__main__":
    if (code := main()) != 0:  # no SystemExit on success: the docs gallery runs it in-process
        raise SystemExit(code)
