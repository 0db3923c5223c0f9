"""Planner -> shortcut -> path optimization -> time parametrization, on the Panda.

1. RRT-Connect finds a collision-free path around a box wall (slide 3:42);
2. shortcutting removes the detours of the random tree;
3. KOMO-style path optimization (section 4) smooths it (acceleration cost) while keeping
   2 cm from the obstacle and the joint limits, warm-started from the shortcut path;
4. time-optimal time parametrization under the Panda's joint velocity and acceleration limits.

Figures: joint paths of the three stages and the timed joint velocities against their limits.
``--save DIR`` also writes the timed motion as ``panda_pipeline.html`` (meshcat animation with
the wall and the tcp's path) and ``panda_pipeline_robot.png`` (the robot closest to the wall).

    python examples/trajectories/panda_pipeline.py --save out/
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

MARGIN = 0.02  # [m]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", help="directory for the figure, animation and robot picture")
    args = parser.parse_args(argv)
    if args.save or os.environ.get("MPLBACKEND", "").lower() == "agg":
        import matplotlib

        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from taskspace import features as F
    from taskspace.constraints import FeatureBounds
    from taskspace.model import Obstacle, Robot
    from taskspace.planning import (
        CollisionChecker,
        ConfigurationSpace,
        path_length,
        rrt_connect,
        shortcut_path,
    )
    from taskspace.tasks import Task
    from taskspace.trajopt import (
        PathEquality,
        PathInequality,
        PathProblem,
        optimize_path,
        time_parametrize,
    )

    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")
    rng = np.random.default_rng(3)
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.box("wall", [0.3, 0.04, 0.5], [0.45, 0.0, 0.35]))
    q_start = robot.q_default.copy()
    q_start[0] = -0.9
    q_goal = robot.q_default.copy()
    q_goal[0] = 0.9
    for name, q in (("start", q_start), ("goal", q_goal)):
        if not robot.is_collision_free(q):
            raise SystemExit(f"{name} configuration collides: {robot.colliding_pairs(q)}")

    space = ConfigurationSpace(robot.lower_limits, robot.upper_limits, CollisionChecker(robot))
    plan = rrt_connect(space, q_start, q_goal, rng=rng)
    print(
        f"RRT-Connect: {plan.status.value}, {len(plan.path)} waypoints, length "
        f"{plan.path_length:.2f} rad, {plan.collision_checks} collision checks, "
        f"{plan.time_s * 1e3:.0f} ms"
    )
    if not plan.success:
        return 1
    short = shortcut_path(space, plan.path, rng=rng)
    print(f"shortcut: length {short.length_before:.2f} -> {short.length_after:.2f} rad")

    T = 20 if fast else 40
    pairs = [p for p in robot.collision_pairs if "wall" in p]
    problem = PathProblem(
        robot,
        q_start,
        T,
        equalities=[PathEquality(Task(F.JointConfiguration(robot), q_goal))],  # end at q_goal
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), MARGIN, np.inf))
        ],
        duration=float(T) * 0.1,
    )
    initial = problem.initial_path(short.path)
    optimized = optimize_path(problem, initial)
    distance = F.CollisionDistance(robot, pairs)
    d_min = min(float(distance.value(robot.state(q)).min()) for q in optimized.path)
    print(
        f"path optimization: {optimized.status.value}, {optimized.iterations} iterations, "
        f"{optimized.solve_time * 1e3:.0f} ms, length {path_length(optimized.path):.2f} rad, "
        f"closest distance {d_min * 1e3:.1f} mm (margin {MARGIN * 1e3:.0f} mm)"
    )

    timed = time_parametrize(optimized.path, robot.velocity_limits, np.full(robot.nv, 5.0))
    print(f"time parametrization: {timed.status.value}, duration {timed.duration:.2f} s")

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for j in range(robot.nv):
        color = f"C{j}"
        s_plan = np.linspace(0, 1, len(short.path))
        axes[0].plot(s_plan, short.path[:, j], "o--", color=color, alpha=0.4, ms=3)
        axes[0].plot(np.linspace(0, 1, T + 1), optimized.path[:, j], "-", color=color)
        axes[1].plot(timed.times, timed.qd[:, j], color=color, label=f"joint {j + 1}")
        axes[1].axhline(robot.velocity_limits[j], color=color, ls=":", lw=0.8)
        axes[1].axhline(-robot.velocity_limits[j], color=color, ls=":", lw=0.8)
    axes[0].set_xlabel("path parameter")
    axes[0].set_ylabel("joint angle [rad]")
    axes[0].set_title("shortcut RRT-Connect path (dashed) and optimized path")
    axes[1].set_xlabel("time [s]")
    axes[1].set_ylabel("joint velocity [rad/s]")
    axes[1].set_title(f"time-optimal timing: {timed.duration:.2f} s (limits dotted)")
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    if args.save:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "panda_pipeline.png", dpi=110)
        print(f"wrote {out / 'panda_pipeline.png'}")
    elif plt.get_backend().lower() != "agg":
        plt.show()
    if args.save:
        from taskspace.viz import Viewer, save_robot_motion

        qs = timed.sample(0.02).q
        closest = int(np.argmin([distance.value(robot.state(q)).min() for q in qs]))
        viewer = Viewer(robot, qs[0])
        viewer.add_frame_trace("tcp_path", qs, "panda_hand_tcp")
        viewer.frame_scene(direction=(1.0, 0.2, 0.6))  # the tcp swings over the wall
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "panda_pipeline",
            dt=0.02,
            title="Panda around a wall: RRT-Connect, shortcut, path optimization, timing",
            picture=closest,
        )
    return 0


if __name__ == "__main__":
    if (code := main()) != 0:  # no SystemExit on success: the docs gallery runs it in-process
        raise SystemExit(code)
