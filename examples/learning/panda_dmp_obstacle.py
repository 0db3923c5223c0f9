"""A Panda reaching around a sphere with a dynamic movement primitive (DMP) feeding an IK task.

A DMP learns a straight minimum-jerk reach of the tcp (40 cm sideways); the sphere sits on
that line. At every 10 ms step the DMP advances online (``DMPTaskTarget``) and its position
is the target of a Position task solved by one differential-IK QP (with a low-weight posture,
joint limits, and velocity dampers between the robot's links and the sphere). Without
coupling the DMP runs along the demonstrated line through the sphere and only the velocity
dampers keep the links 1 cm off it (the tcp then lags the target); with the repulsive
coupling term (``SphereRepulsion``) the DMP's path bends around the sphere and still ends at
the goal. The figure shows both paths from the side and the tcp-sphere distances over time.

Run: ``python examples/learning/panda_dmp_obstacle.py [--save DIR]`` (``TASKSPACE_FAST=1``
for a short run); ``--save`` also writes the coupled run as ``panda_dmp_obstacle.html``
(meshcat animation with both DMP paths) and ``panda_dmp_obstacle_robot.png`` (the robot
closest to the sphere).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.constraints import CollisionAvoidance, JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration, Position
from taskspace.ik import DifferentialIK
from taskspace.learning import DiscreteDMP, DMPTaskTarget, SphereRepulsion
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task

DT = 0.01  # [s]
RADIUS = 0.05  # sphere radius [m]
TCP_MARGIN = 0.04  # the hand around the tcp point: the DMP keeps this much extra [m]


def run(
    robot: Robot, dmp: DiscreteDMP, coupling: SphereRepulsion | None, steps: int
) -> dict[str, np.ndarray]:
    """DMP -> Position task -> differential IK: DMP path, tcp path, distances, configurations."""
    state = robot.state()
    tcp = Task(Position(robot, "panda_hand_tcp"), dmp.y0)
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3)
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    damper = CollisionAvoidance(robot, 0.01, 0.05, gain=0.5, pairs=pairs)
    ik = DifferentialIK(
        robot, [tcp, posture], [JointPositionLimits(robot), JointVelocityLimits(robot), damper]
    )
    driver = DMPTaskTarget(dmp, tcp, couplings=[coupling] if coupling else [])
    path, tcp_path, link_dist, qs = [], [], [], [state.q.copy()]
    for _ in range(steps):
        path.append(driver.step(DT).y)
        q, _ = ik.step(state, DT)
        state.update(q)
        tcp_path.append(robot.frame_placement(q, "panda_hand_tcp").translation.copy())
        link_dist.append(float(damper.distances.value(state).min()))
        qs.append(q.copy())
    return {
        "t": DT * np.arange(1, steps + 1),
        "dmp": np.array(path),
        "tcp": np.array(tcp_path),
        "links": np.array(link_dist),
        "q": np.array(qs),
    }


def main() -> None:
    """Run the example (see the module docstring)."""
    args = parse(__doc__ or "")
    steps = 150 if fast() else 250
    robot = Robot.load("panda", convex_collision=True)
    start = robot.frame_placement(robot.q_default, "panda_hand_tcp").translation.copy()
    goal = start + np.array([0.0, 0.4, 0.0])
    t = np.linspace(0.0, 1.5, 151)
    s = t / t[-1]
    line = start + (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None] * (goal - start)
    dmp = DiscreteDMP.fit(t, line)
    center = start + np.array([0.0, 0.2, -0.04])
    robot.add_obstacle(Obstacle.sphere("ball", RADIUS, center))
    repulsion = SphereRepulsion(center=center, radius=RADIUS + TCP_MARGIN, influence=0.1, gain=2e-3)

    runs = {
        "no coupling": run(robot, dmp, None, steps),
        "sphere coupling": run(robot, dmp, repulsion, steps),
    }
    for name, r in runs.items():
        d_tcp = np.linalg.norm(r["tcp"] - center, axis=1) - RADIUS
        print(
            f"{name}: min tcp-sphere distance {d_tcp.min():.3f} m, min link-sphere distance "
            f"{r['links'].min():.3f} m, final tcp error {np.linalg.norm(r['tcp'][-1] - goal):.4f} m"
        )

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax1.add_patch(plt.Circle((center[1], center[2]), RADIUS, color="0.6", label="sphere"))
    for (name, r), style in zip(runs.items(), ("--", "-")):
        ax1.plot(r["dmp"][:, 1], r["dmp"][:, 2], style, lw=2, label=f"DMP, {name}")
        ax1.plot(r["tcp"][:, 1], r["tcp"][:, 2], ":", label=f"tcp, {name}")
    ax1.plot(*start[1:], "ko")
    ax1.plot(*goal[1:], "k*", ms=12)
    ax1.set_aspect("equal")
    ax1.set_xlabel("y [m]")
    ax1.set_ylabel("z [m]")
    ax1.set_title("paths from the side")
    ax1.legend(fontsize=8)
    for (name, r), style in zip(runs.items(), ("--", "-")):
        ax2.plot(
            r["t"], np.linalg.norm(r["tcp"] - center, axis=1) - RADIUS, style, label=f"tcp, {name}"
        )
        ax2.plot(r["t"], r["links"], style, alpha=0.5, label=f"closest link, {name}")
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("distance to the sphere [m]")
    ax2.legend(fontsize=8)
    fig.suptitle("Panda DMP reach: a repulsive coupling term bends the primitive around a sphere")
    fig.tight_layout()
    finish({"panda_dmp_obstacle": fig}, args.save)
    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        r = runs["sphere coupling"]
        viewer = Viewer(robot, r["q"][0])
        viewer.add_path("dmp_path", r["dmp"], color=(0.1, 0.5, 0.9))
        viewer.add_path("dmp_path_uncoupled", runs["no coupling"]["dmp"], color=(0.6, 0.6, 0.6))
        viewer.add_target("goal", goal)
        closest = int(np.argmin(np.linalg.norm(r["tcp"] - center, axis=1))) + 1
        viewer.frame_scene(direction=(1.0, 0.1, 0.35))  # from the front: the bend is in y-z
        save_robot_motion(
            viewer,
            r["q"],
            args.save,
            "panda_dmp_obstacle",
            dt=DT,
            title="Panda DMP reach bent around a sphere (coupled DMP in blue, demonstration gray)",
            picture=closest,
        )


if __name__ == "__main__":
    main()
