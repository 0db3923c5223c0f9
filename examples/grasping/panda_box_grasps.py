"""The best antipodal Panda grasps on a box and a cylinder, placed by IK, shown in meshcat.

Antipodal contact pairs are sampled on each object's mesh, ranked by the Ferrari-Canny epsilon
of two soft-finger contacts, and the best ones are reached by the arm (``solve_ik`` over
approach directions) with the gripper open, keeping the collision-free configurations.
``--save DIR`` writes ``panda_box_grasps.html`` (meshcat animation: the arm moving from its
default posture to the best grasp of the box, planned by RRT-Connect around it) and
``panda_box_grasps_robot.png`` (the robot at that grasp with the contact points of the five
best candidates).

Run: ``python examples/grasping/panda_box_grasps.py [--save DIR]``.
"""

from __future__ import annotations

import argparse
import itertools
import os
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from taskspace.grasping import (
    AntipodalOptions,
    box_mesh,
    cylinder_mesh,
    force_closure,
    place_grasps,
    sample_antipodal_grasps,
)
from taskspace.model import Obstacle, Robot
from taskspace.planning import ConfigurationSpace, rrt_connect, shortcut_path
from taskspace.planning.configuration_space import EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions

OPEN = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}


def approach_motion(robot: Robot, q_grasp: np.ndarray) -> np.ndarray:
    """Configurations from the default posture to the grasp, around the object (0.01 rad apart).

    A collision-free path planned by RRT-Connect among the robot's obstacles and shortcut,
    its edges checked every 0.01 rad (the fingers pass within millimeters of the object).
    """
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.01))
    plan = rrt_connect(space, robot.q_default, q_grasp, RRTConnectOptions(seed=0))
    if not plan.success:
        return np.array([robot.q_default, q_grasp])
    path = shortcut_path(space, plan.path).path
    dense = [path[0]]
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.01)))
        dense.extend(a + (b - a) * t for t in np.linspace(0.0, 1.0, n + 1)[1:])
    return np.array(dense)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the example (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory for the HTML and PNG")
    args = parser.parse_args(argv)
    fast = os.environ.get("TASKSPACE_FAST", "") not in ("", "0")
    rng = np.random.default_rng(0)
    robot = Robot.load("panda", locked_values=OPEN)
    objects = {
        "box": (box_mesh([0.04, 0.05, 0.15]), pin.SE3(np.eye(3), np.array([0.5, 0.0, 0.3]))),
        "cylinder": (cylinder_mesh(0.03, 0.14), pin.SE3(np.eye(3), np.array([0.45, 0.2, 0.3]))),
    }
    best = {}
    for name, (mesh, pose) in objects.items():
        candidates = sample_antipodal_grasps(
            mesh, rng, AntipodalOptions(samples=200 if fast else 1000)
        )
        placed = place_grasps(robot, mesh, pose, candidates, rng, top=6 if fast else 15)
        feasible = [g for g in placed if g.feasible]
        print(
            f"{name}: {len(candidates)} antipodal candidates, best epsilon "
            f"{candidates.epsilon[0]:.4f}; {len(feasible)} placed collision-free of "
            f"{len(placed)} tried"
        )
        if feasible:
            g = feasible[0]
            closed = force_closure(candidates.contacts(g.candidate)).closure
            print(
                f"  best placed grasp: candidate {g.candidate}, epsilon {g.epsilon:.4f}, "
                f"width {candidates.width[g.candidate] * 100:.1f} cm, closure {closed}"
            )
            best[name] = (g, candidates, mesh, pose)
    if args.save and "box" not in best:
        print("no collision-free grasp of the box was placed: no animation written")
    if args.save and "box" in best:
        from taskspace.viz import Viewer, save_robot_motion

        g, candidates, mesh, pose = best["box"]
        scene_robot = Robot.load("panda", locked_values=OPEN)
        scene_robot.add_obstacle(
            Obstacle("box", mesh.collision_geometry(), pose, color=np.array([0.9, 0.5, 0.1, 1]))
        )
        approach = approach_motion(scene_robot, g.q)
        hits = sum(not scene_robot.is_collision_free(q) for q in approach)
        print(f"approach: {len(approach)} configurations, {hits} touching the box")
        viewer = Viewer(scene_robot, g.q)
        contacts = np.vstack([candidates.p1[:5], candidates.p2[:5]])
        viewer.add_points("contacts", np.array([pose.act(p) for p in contacts]), color=0xD62728)
        viewer.add_frame("grasp", g.tool_pose, scale=0.08)
        viewer.set_camera(pose.translation + np.array([0.45, -0.55, 0.3]), pose.translation)
        save_robot_motion(
            viewer, approach, args.save, "panda_box_grasps", dt=0.01, title="Panda grasps on a box"
        )


if __name__ == "__main__":
    main()
