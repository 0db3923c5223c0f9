"""Panda reaching around a sphere with path optimization (KOMO-style, slides 4:1-4:4).

The whole path q_1..q_T is optimized at once: acceleration cost, final hand pose as a hard
equality, every link at least 2 cm from the sphere and the joint limits as hard inequalities
(augmented Lagrangian, banded Gauss-Newton). The initial guess is the straight joint-space
line, which runs through the sphere: the repair step pushes those slices out first.

Figures: cost and constraint violation per iteration; distance to the sphere along the path.
``--save DIR`` also writes the optimized motion as ``panda_path_optimization.html`` (meshcat
animation with the sphere and the tcp's path) and ``panda_path_optimization_robot.png`` (the
robot closest to the sphere); ``--html FILE`` writes the same animation to ``FILE``.

Run: python examples/trajectories/panda_path_optimization.py [--save DIR] [--html FILE]
(``TASKSPACE_FAST=1``: shorter horizon).
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task
from taskspace.trajopt.path_optimization import (
    PathEquality,
    PathInequality,
    PathProblem,
    optimize_path,
)
from taskspace.viz.plots import save_or_show

TCP = "panda_hand_tcp"
MARGIN = 0.02


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory or .png file for the figures")
    parser.add_argument("--html", default=None, help="write an animated meshcat HTML file")
    args = parser.parse_args()
    if args.save is not None or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")

    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("ball", 0.12, [0.35, 0.0, 0.4]))
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    q_start = robot.q_default.copy()
    q_start[0] = -0.8
    q_goal = robot.q_default.copy()
    q_goal[0] = 0.8
    T = 20 if fast else 60
    duration = 3.0  # [s]

    problem = PathProblem(
        robot,
        q_start,
        T,
        equalities=[
            PathEquality(Task(F.FramePose(robot, TCP), robot.frame_placement(q_goal, TCP)))
        ],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), MARGIN, np.inf))
        ],
        duration=duration,
    )
    straight = np.linspace(q_start, q_goal, T + 1)
    result = optimize_path(problem, straight)
    print(
        f"{result.status.value}: {result.iterations} iterations ({result.outer_iterations} "
        f"multiplier updates), {result.solve_time * 1e3:.1f} ms, "
        f"{result.repaired_slices} slices repaired, max violation {result.max_violation:.2e}"
    )

    distance = F.CollisionDistance(robot, pairs)
    d_initial = [distance.value(robot.state(q)).min() for q in straight]
    d_final = [distance.value(robot.state(q)).min() for q in result.path]

    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ax = axes[0]
    ax.semilogy(result.cost_history, "o-", label="cost f (control + tasks)")
    ax.semilogy(np.maximum(result.violation_history, 1e-12), "s-", label="max violation")
    ax.axhline(1e-4, color="gray", ls=":", label="tolerance")
    ax.set_xlabel("accepted iteration")
    ax.set_title("augmented Lagrangian + banded Gauss-Newton")
    ax.legend()
    ax = axes[1]
    time_axis = np.linspace(0.0, duration, T + 1)
    ax.plot(time_axis, d_initial, "--", label="initial guess (straight line)")
    ax.plot(time_axis, d_final, "-", label="optimized path")
    ax.axhline(MARGIN, color="r", ls=":", label=f"margin {MARGIN} m")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("closest link-sphere distance [m]")
    ax.set_title(f"Panda around a sphere, T = {T}")
    ax.legend()
    fig.tight_layout()
    out = save_or_show(fig, args.save, "panda_path_optimization")
    if out is not None:
        print(f"wrote {out}")

    if args.html is not None or args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        title = "Panda around a sphere: path optimization"
        viewer = Viewer(robot, q_start)
        viewer.add_frame_trace("tcp_path", result.path, TCP)
        viewer.frame_scene(direction=(1.0, 0.1, 0.9))  # from above the sphere: the detour
        save_robot_motion(
            viewer,
            result.path,
            args.save,
            "panda_path_optimization",
            dt=duration / T,
            title=title,
            picture=int(np.argmin(d_final)),
        )
        if args.html is not None:
            viewer.play(result.path, duration / T, autoplay=False)
            out = viewer.save_html(args.html, title=title)
            print(f"wrote {out}")


if __name__ == "__main__":
    main()
