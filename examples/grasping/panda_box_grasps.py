"""The best antipodal Panda grasps on a box and a cylinder, placed by IK, shown in meshcat.

Antipodal contact pairs are sampled on each object's mesh, ranked by the Ferrari-Canny epsilon
of two soft-finger contacts, and the best ones are reached by the arm (``solve_ik`` over
approach directions) with the gripper open, keeping the collision-free configurations. The
snapshot shows the robot at the best grasp of the box and the contact points of the five best
candidates.

Run: ``python examples/grasping/panda_box_grasps.py [--save DIR]``.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

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

OPEN = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}


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
    if args.save and "box" in best:
        from taskspace.viz import Viewer

        g, candidates, mesh, pose = best["box"]
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        scene_robot = Robot.load("panda", locked_values=OPEN)
        scene_robot.add_obstacle(
            Obstacle("box", mesh.collision_geometry(), pose, color=np.array([0.9, 0.5, 0.1, 1]))
        )
        viewer = Viewer(scene_robot, g.q)
        contacts = np.vstack([candidates.p1[:5], candidates.p2[:5]])
        viewer.add_points("contacts", np.array([pose.act(p) for p in contacts]), color=0xD62728)
        viewer.add_frame("grasp", g.tool_pose, scale=0.08)
        viewer.set_camera(pose.translation + np.array([0.45, -0.55, 0.3]), pose.translation)
        html = viewer.save_html(out / "panda_box_grasps.html", title="Panda grasps on a box")
        print(f"wrote {html}")
        png = out / "panda_box_grasps.png"
        viewer.snapshot(png)
        print(f"wrote {png}")


if __name__ == "__main__":
    main()
