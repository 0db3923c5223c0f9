"""Sampling-based planning (slides 3:28-3:43): RRT growth, goal bias, PRM, and a Panda in a shelf.

Figures:

1. RRT growth of a point robot in a 2-D world at n = 1, 100, 300, 600, 1000, 2000 (slide 3:38);
2. goal-biased RRT growth (beta = 0.1) until the goal is reached (slide 3:41);
3. a PRM graph with its shortest path (slides 3:29-3:30);
4. a Panda planning through a MotionBenchMaker bookshelf with RRT-Connect + shortcutting:
   its joint trajectories; with ``--save DIR`` also ``panda_shelf.html`` (meshcat animation
   of the motion in the shelf) and ``panda_shelf_robot.png`` (the robot at its goal in the
   shelf); without ``--save`` (and with a display) the motion plays in a live meshcat viewer.
   The Panda part needs the MotionBenchMaker problems (``--data`` or
   ``TASKSPACE_MOTIONBENCHMAKER_DIR``); without them it is skipped, with a message.

Usage: python examples/planning/panda_shelf.py [--save DIR] [--data MOTIONBENCHMAKER_DIR];
TASKSPACE_FAST=1 for a quick run.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from taskspace.errors import ModelLoadError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.prm import PRMOptions, prm
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.shortcut import shortcut_path
from taskspace.viz.plots import save_or_show, style_figure, use_agg_if_headless


def _save(fig, save: str | None, name: str) -> None:  # type: ignore[no-untyped-def]
    """Save (or show) a figure and say where it went."""
    out = save_or_show(fig, save, name)
    if out is not None:
        print(f"wrote {out}")


FAST = os.environ.get("TASKSPACE_FAST") == "1"
BOXES = np.array([[3.0, 0.0, 4.0, 6.5], [6.0, 3.5, 7.0, 10.0], [1.0, 7.5, 4.5, 8.5]])


def world_space() -> ConfigurationSpace:
    """Point robot in [0, 10]^2 among axis-aligned boxes."""

    def free(q: np.ndarray) -> np.ndarray:
        x, y = q[:, 0:1], q[:, 1:2]
        b = BOXES
        inside = (x >= b[:, 0]) & (x <= b[:, 2]) & (y >= b[:, 1]) & (y <= b[:, 3])
        return ~inside.any(axis=1)

    return ConfigurationSpace(
        [0, 0], [10, 10], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.02)
    )


def draw_world(ax) -> None:  # type: ignore[no-untyped-def]
    from matplotlib.patches import Rectangle

    for x0, y0, x1, y1 in BOXES:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.4"))
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def draw_tree(ax, tree, color: str = "tab:blue") -> None:  # type: ignore[no-untyped-def]
    from matplotlib.collections import LineCollection

    if tree.size > 1:
        ax.add_collection(LineCollection(tree.edges(), colors=color, linewidths=0.6))


def rrt_figures(save: str | None) -> None:
    import matplotlib.pyplot as plt

    space = world_space()
    start, goal = np.array([1.0, 1.0]), np.array([9.0, 9.0])
    counts = [1, 100, 300, 600, 1000, 2000]
    if FAST:
        counts = [1, 50, 100, 200, 300, 400]
    fig, axes = plt.subplots(1, len(counts), figsize=(3 * len(counts), 3.2))
    for ax, n in zip(axes, counts):
        res = rrt(space, start, None, RRTOptions(step_size=0.3, max_iterations=n, seed=1))
        draw_world(ax)
        draw_tree(ax, res.trees[0])
        ax.set_title(f"n = {n}")
    _save(style_figure(fig, "RRT growth (slide 3:38)", grid=False), save, "rrt_growth")

    res = rrt(space, start, goal, RRTOptions(step_size=0.3, goal_bias=0.1, seed=1))
    sizes = [1, 100, 200, 300, 400, 500]
    fig, axes = plt.subplots(1, len(sizes), figsize=(3 * len(sizes), 3.2))
    tree = res.trees[0]
    for ax, n in zip(axes, sizes):
        draw_world(ax)
        m = min(n, tree.size)
        from taskspace.planning.planner_result import Tree

        draw_tree(ax, Tree(nodes=tree.nodes[:m], parents=tree.parents[:m]), "tab:green")
        ax.plot(*goal, "r*", ms=10)
        if m == tree.size and res.success:
            ax.plot(res.path[:, 0], res.path[:, 1], "r-", lw=2)
        ax.set_title(f"n = {m}")
    _save(
        style_figure(fig, "goal-biased RRT, beta = 0.1 (slide 3:41)", grid=False),
        save,
        "rrt_goal_bias",
    )

    result, roadmap = prm(
        space, start, goal, PRMOptions(max_iterations=150 if FAST else 400, k_neighbors=8, seed=2)
    )
    fig, ax = plt.subplots(figsize=(5, 5))
    draw_world(ax)
    from matplotlib.collections import LineCollection

    e = roadmap.edges
    ax.add_collection(LineCollection(roadmap.nodes[e], colors="tab:blue", linewidths=0.5))
    ax.plot(roadmap.nodes[:, 0], roadmap.nodes[:, 1], "k.", ms=3)
    if result.success:
        ax.plot(result.path[:, 0], result.path[:, 1], "r-", lw=2, label="Dijkstra path")
        ax.legend(loc="lower right")
    ax.set_title(f"PRM, n = {roadmap.size}, k = 8")
    _save(style_figure(fig, grid=False), save, "prm_graph")


def panda_shelf(save: str | None, data: str | None) -> None:
    try:
        root = motionbenchmaker_dir(data)
    except ModelLoadError as exc:
        print(f"{exc}: skipping the Panda part")
        return
    robot = motionbenchmaker_panda()
    problem = motionbenchmaker_problems(root, "bookshelf_small", [2])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot)
    res = rrt_connect(space, req.start, req.goal, RRTConnectOptions(time_limit_s=5.0, seed=0))
    print(
        f"RRT-Connect: {res.status.value} in {res.time_s * 1e3:.0f} ms, "
        f"{res.collision_checks} collision checks, {res.trees[0].size + res.trees[1].size} nodes"
    )
    if not res.success:
        return
    short = shortcut_path(space, res.path)
    print(
        f"path length {short.length_before:.2f} -> {short.length_after:.2f} rad after shortcutting"
    )
    # Dense joint trajectory (straight segments at 0.02 rad).
    dense = [short.path[0]]
    for a, b in zip(short.path[:-1], short.path[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.02)))
        dense.extend(a + (b - a) * t for t in np.linspace(0, 1, n + 1)[1:])
    trajectory = np.asarray(dense)
    from taskspace.viz import Viewer, save_robot_motion

    if save is not None:
        viewer = Viewer(robot, trajectory[0])
        viewer.add_frame_trace("tcp_path", trajectory, robot.end_effectors[0])
        viewer.frame_scene(direction=(-0.8, -0.9, 0.9))  # over the robot's shoulder, into the shelf
        save_robot_motion(
            viewer,
            trajectory,
            save,
            "panda_shelf",
            dt=0.02,
            title="Panda in a bookshelf: RRT-Connect + shortcut",
        )
    elif os.environ.get("MPLBACKEND", "").lower() != "agg" and not FAST:
        viewer = Viewer(robot, trajectory[0], live=True)
        viewer.play(trajectory, dt=0.02)
        viewer.open()
        print(f"meshcat viewer: {viewer.url} (press Ctrl-C to stop)", flush=True)
        viewer.wait_until_interrupted()
        return
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(trajectory, axis=0), axis=1))])
    for j in range(trajectory.shape[1]):
        ax.plot(s, trajectory[:, j], label=f"joint {j + 1}")
    ax.set_xlabel("path length [rad]")
    ax.set_ylabel("q [rad]")
    ax.legend(ncol=4, fontsize=8)
    _save(style_figure(fig, "Panda in a bookshelf: RRT-Connect + shortcut"), save, "panda_shelf")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory (or .png file) for the figures")
    parser.add_argument(
        "--data",
        default=None,
        help="MotionBenchMaker Panda directory (default: $TASKSPACE_MOTIONBENCHMAKER_DIR)",
    )
    args = parser.parse_args()
    use_agg_if_headless(args.save)
    rrt_figures(args.save)
    panda_shelf(args.save, args.data)


if __name__ == "__main__":
    main()
