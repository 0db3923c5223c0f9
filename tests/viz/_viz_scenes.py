"""Named scenes of the snapshot tests (deterministic: fixed configurations, no randomness)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from taskspace.model import Obstacle, Robot
from taskspace.viz import Viewer

PANDA_IK_Q = np.array([0.3, -0.2, -0.1, -2.0, 0.1, 1.9, 0.6])


def panda_default(panda: Robot) -> Viewer:
    return Viewer(panda)


def panda_ik_target(panda: Robot, q: np.ndarray = PANDA_IK_Q) -> Viewer:
    viewer = Viewer(panda, q)
    viewer.add_target("target", panda.frame_placement(q, "panda_hand_tcp"), scale=0.12)
    return viewer


def panda_path_with_obstacle(panda: Robot) -> Viewer:
    # A private copy of the model: tests must not add obstacles to the shared robot.
    robot = Robot.load("panda")
    robot.add_obstacle(
        Obstacle.box("box", [0.2, 0.3, 0.3], [0.5, 0.0, 0.15], color=np.array([0.8, 0.3, 0.2, 1]))
    )
    q0 = np.array([-0.8, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785])
    q1 = np.array([0.8, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785])
    lift = np.array([0.0, -0.6, 0.0, 0.5, 0.0, -0.3, 0.0])
    s = np.linspace(0.0, 1.0, 41)[:, None]
    qs = (1 - s) * q0 + s * q1 + np.sin(np.pi * s) * lift
    viewer = Viewer(robot, qs[20])
    viewer.add_frame_trace("ee_path", qs, radius=0.006)
    return viewer


def humanoid_contacts(talos: Robot) -> Viewer:
    viewer = Viewer(talos)
    q = talos.q_default
    weight = talos.mass * 9.81
    for foot, lateral in (("left_sole_link", -60.0), ("right_sole_link", 60.0)):
        point = talos.frame_placement(q, foot).translation
        viewer.add_force(f"force_{foot}", point, [40.0, lateral, weight / 2], scale=0.0012)
    viewer.add_com("com", radius=0.05)
    return viewer


SCENES: dict[str, tuple[str, Callable[[Robot], Viewer]]] = {
    "panda_default": ("panda", panda_default),
    "panda_ik_target": ("panda", panda_ik_target),
    "panda_path_obstacle": ("panda", panda_path_with_obstacle),
    "talos_contacts": ("talos", humanoid_contacts),
}

del pin
