"""Panda reaching past a sphere with joint limits and collision avoidance (slides 2:25-2:29).

Each 10 ms step solves one weighted differential-IK QP: the tcp position task (gain 0.05), a
low-weight posture, joint position and velocity limits, and velocity dampers
``J_d dq >= -gain (d - d_s)`` on the distances between the robot and the sphere (convex
collision hulls). The figure shows the robot-obstacle distance over time, with and without
the dampers, against the safety distance.

In a weighted QP the posture task pulls against the tcp task: at rest their gradients cancel,
so the tcp stops short of its goal by an error that grows with ``w_posture g_posture`` over
``w_tcp g_tcp``. With the posture at the tcp's gain (0.05) and weight 1e-3 the tcp ends 4.2 cm
away; at gain 0.01 the error after 4 s is 0.5 mm (a strict hierarchy, ``HierarchicalIK``,
removes it altogether).

Run: ``python examples/ik/panda_reach_obstacle.py [--save DIR]`` (``TASKSPACE_FAST=1`` for a
short run); ``--save`` also writes the motion as ``panda_reach_obstacle.html`` (meshcat
animation) and ``panda_reach_obstacle_robot.png`` (the final pose).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from taskspace.constraints import (
    CollisionAvoidance,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.features import JointConfiguration, Position
from taskspace.ik import DifferentialIK
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task

SAFETY = 0.02  # [m]
INFLUENCE = 0.1  # [m]
DT = 0.01  # [s]
POSTURE_GAIN = 0.01  # a fifth of the tcp's: the posture barely pulls the tcp off its goal


def run(robot: Robot, goal: np.ndarray, steps: int, avoid: bool) -> dict[str, np.ndarray]:
    """Run the reaching loop; returns times [s], obstacle distances [m], tcp errors [m], q."""
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    state = robot.state()
    tcp = Task(Position(robot, "panda_hand_tcp"), goal, gain=0.05)
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3, gain=POSTURE_GAIN)
    constraints = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    damper = CollisionAvoidance(robot, SAFETY, INFLUENCE, gain=0.5, pairs=pairs)
    if avoid:
        constraints.append(damper)
    ik = DifferentialIK(robot, [tcp, posture], constraints)
    distances, errors, qs = [], [], [state.q.copy()]
    for _ in range(steps):
        q, _ = ik.step(state, DT)
        state.update(q)
        distances.append(float(damper.distances.value(state).min()))
        errors.append(float(np.linalg.norm(tcp.error(state))))
        qs.append(q)
    return {
        "t": DT * np.arange(1, steps + 1),
        "distance": np.array(distances),
        "error": np.array(errors),
        "q": np.array(qs),
    }


def main(argv: Sequence[str] | None = None) -> None:
    """Run the example (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory for the PNG figure")
    args = parser.parse_args(argv)
    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")
    steps = 120 if fast else 400

    robot = Robot.load("panda", convex_collision=True)
    start = robot.frame_placement(robot.q_default, "panda_hand_tcp").translation.copy()
    goal = start + np.array([0.0, 0.4, 0.0])
    robot.add_obstacle(Obstacle.sphere("ball", 0.06, start + np.array([0.0, 0.2, 0.0])))

    with_dampers = run(robot, goal, steps, avoid=True)
    without = run(robot, goal, steps, avoid=False)
    print(
        f"with dampers: min distance {with_dampers['distance'].min():.4f} m "
        f"(safety {SAFETY} m), final tcp error {with_dampers['error'][-1]:.4f} m"
    )
    print(f"without dampers: min distance {without['distance'].min():.4f} m")

    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        viewer = Viewer(robot, with_dampers["q"][0])
        viewer.add_target("goal", goal)
        save_robot_motion(
            viewer,
            with_dampers["q"],
            args.save,
            "panda_reach_obstacle",
            dt=DT,
            title="Panda reaching past a sphere with velocity dampers",
        )

    import matplotlib

    if args.save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax1.plot(with_dampers["t"], with_dampers["distance"], label="with velocity dampers")
    ax1.plot(without["t"], without["distance"], "--", label="without")
    ax1.axhline(SAFETY, color="k", lw=0.8, label="safety distance")
    ax1.axhline(INFLUENCE, color="gray", lw=0.8, ls=":", label="influence distance")
    ax1.set_ylabel("robot-sphere distance [m]")
    ax1.legend()
    ax2.plot(with_dampers["t"], with_dampers["error"], label="with velocity dampers")
    ax2.plot(without["t"], without["error"], "--", label="without")
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("tcp error [m]")
    ax2.legend()
    fig.suptitle("Panda reaching past a sphere (slides 2:25-2:29)")
    fig.tight_layout()
    if args.save is not None:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "panda_reach_obstacle.png", dpi=110)
        print(f"saved {out / 'panda_reach_obstacle.png'}")
    elif plt.get_backend().lower() != "agg":
        plt.show()


if __name__ == "__main__":
    main()
