"""A Robot shared by threads (#15 Build 5): its own Pinocchio data is guarded.

``Robot.colliding_pairs`` computes the collisions into the robot's ``collision_data`` and then
reads the results pair by pair; another thread's query in between overwrote them (seen: ~1 %
wrong pair lists over 2 threads x 2000 calls with a 1 us switch interval). The reference is
Pinocchio's ``computeCollisions`` / ``framesForwardKinematics`` on fresh data of the same models.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.model import Obstacle, Robot
from tests._threads import fast_switching, run_in_threads

CALLS = 1500


def _reference_pairs(robot: Robot, q: np.ndarray) -> list[tuple[str, str]]:
    gm = robot.collision_model
    gdata = gm.createData()
    pin.computeCollisions(robot.model, robot.model.createData(), gm, gdata, q, False)
    objs = gm.geometryObjects
    return sorted(
        (objs[p.first].name, objs[p.second].name)
        for k, p in enumerate(gm.collisionPairs)
        if gdata.collisionResults[k].isCollision()
    )


def test_colliding_pairs_and_frame_placement_from_two_threads() -> None:
    robot = Robot.load("panda")
    robot.add_obstacle(Obstacle.box("wall", [0.2, 2.0, 2.0], pose=(0.5, 0.0, 0.5)))
    rng = np.random.default_rng(1)
    cases: dict[bool, tuple[np.ndarray, list[tuple[str, str]]]] = {}
    while len(cases) < 2:
        q = robot.random_configuration(rng)
        pairs = _reference_pairs(robot, q)
        cases.setdefault(bool(pairs), (q, pairs))
    frame = "panda_hand"
    placements = {}
    for hit, (q, _) in cases.items():
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, q)
        placements[hit] = data.oMf[robot.model.getFrameId(frame)].homogeneous.copy()

    def work(i: int) -> tuple[int, int]:
        q, pairs = cases[i == 0]
        wrong_pairs = wrong_pose = 0
        for _ in range(CALLS):
            wrong_pairs += sorted(robot.colliding_pairs(q)) != pairs
            wrong_pose += not np.allclose(
                robot.frame_placement(q, frame).homogeneous, placements[i == 0], atol=1e-12
            )
        return wrong_pairs, wrong_pose

    with fast_switching(1e-6):
        results = run_in_threads(work, threads=2)
    assert results == [(0, 0), (0, 0)]
