"""G1 humanoid moving both hands while keeping its feet and CoM: weighted vs 4-level hierarchy.

Weighted (slides 2:39-2:41): one QP ``min sum_i rho_i |J_i dq + gain_i e_i|^2 + mu |dq|^2``
with feet rho = 100, CoM rho = 10, hands rho = 1, posture rho = 1e-3. Hierarchy (slides
2:42-2:44): the lexicographic cascade feet > CoM > hands > posture, each level solved in the
nullspace of the ones above. Both with joint position and velocity limits. The figure shows
the per-level task errors over time for both.

Run: ``python examples/ik/g1_hands_hierarchy.py [--save DIR]`` (``TASKSPACE_FAST=1`` for a
short run); ``--save`` also writes the hierarchy's motion as ``g1_hands_hierarchy.html``
(meshcat animation, with the hands' paths) and ``g1_hands_hierarchy_robot.png`` (the robot
with its hands farthest from their start).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Position
from taskspace.ik import DifferentialIK, HierarchicalIK
from taskspace.model import Robot
from taskspace.tasks import Task

DT = 0.005  # [s]
FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
HANDS = ("left_rubber_hand", "right_rubber_hand")
LEVELS = ("feet", "CoM", "hands", "posture")


def hand_offset(k: int) -> np.ndarray:
    """Hand displacement at step k [m] (the IK benchmark trajectory, twice as fast)."""
    k = 2 * k
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )


def run(robot: Robot, steps: int, hierarchical: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per-level task error norms after each step, shape (steps, 4), and the (steps + 1, nq)
    configurations."""
    state = robot.state()
    weights = (100.0, 10.0, 1.0, 1e-3)
    feet = [Task(FramePose(robot, f), weight=weights[0]) for f in FEET]
    com = Task(CenterOfMass(robot), weight=weights[1])
    hands = [Task(Position(robot, f), weight=weights[2]) for f in HANDS]
    for task in [*feet, com, *hands]:
        task.set_target_from_state(state)
    # a low gain keeps the lowest-priority posture from driving large nullspace steps
    posture = Task(JointConfiguration(robot), robot.q_default, weight=weights[3], gain=0.05)
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    levels = [feet, [com], hands, [posture]]
    solver: DifferentialIK | HierarchicalIK
    if hierarchical:
        solver = HierarchicalIK(robot, levels, limits)
    else:
        solver = DifferentialIK(robot, [*feet, com, *hands, posture], limits)
    start = [h.target.copy() for h in hands]
    mirror = np.array([1.0, -1.0, 1.0])
    out = np.zeros((steps, 4))
    qs = [state.q.copy()]
    for k in range(steps):
        hands[0].set_target(start[0] + hand_offset(k))
        hands[1].set_target(start[1] + mirror * hand_offset(k))
        q, _ = solver.step(state, DT)
        state.update(q)
        qs.append(q.copy())
        for i, level in enumerate(levels):
            out[k, i] = float(np.sqrt(sum(np.sum(t.error(state) ** 2) for t in level)))
    return out, np.array(qs)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the example (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory for the figure and animation")
    args = parser.parse_args(argv)
    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")
    steps = 60 if fast else 600

    robot = Robot.load("g1")
    weighted, _ = run(robot, steps, hierarchical=False)
    hierarchy, qs = run(robot, steps, hierarchical=True)
    for name, errors in (("weighted", weighted), ("hierarchy", hierarchy)):
        worst = ", ".join(f"{lv} {errors[:, i].max():.2e}" for i, lv in enumerate(LEVELS))
        print(f"{name:9s} worst errors: {worst}")

    import matplotlib

    if args.save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = DT * np.arange(1, steps + 1)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, errors, title in (
        (axes[0], weighted, "weighted (rho = 100, 10, 1, 1e-3)"),
        (axes[1], hierarchy, "strict hierarchy (4 levels)"),
    ):
        for i, level in enumerate(LEVELS):
            ax.semilogy(t, np.maximum(errors[:, i], 1e-16), label=f"{i + 1}: {level}")
        ax.set_title(title)
        ax.set_xlabel("time [s]")
        ax.grid(True, which="both", lw=0.3)
    axes[0].set_ylabel("task error norm [m, rad]")
    axes[1].legend()
    fig.suptitle("G1: hands move, feet and CoM held (slides 2:39-2:44)")
    fig.tight_layout()
    if args.save is not None:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "g1_hands_hierarchy.png", dpi=110)
        print(f"wrote {out / 'g1_hands_hierarchy.png'}")
    elif plt.get_backend().lower() != "agg":
        plt.show()

    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        viewer = Viewer(robot, qs[0])
        for hand in HANDS:
            viewer.add_frame_trace(f"{hand}_path", qs, hand)
        offsets = [np.linalg.norm(hand_offset(k)) for k in range(steps)]
        viewer.frame_scene(direction=(1.0, -0.35, 0.3))  # from the front, a little to the right
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "g1_hands_hierarchy",
            dt=DT,
            title="G1: hands move, feet and CoM held (strict hierarchy)",
            picture=int(np.argmax(offsets)) + 1,
        )


if __name__ == "__main__":
    main()
