"""Alignment features with vectors that are not unit length (audit5).

Alignment documents "1 aligned, -1 anti-aligned, 0 orthogonal" (the notes, slide 2:50), but
the value was ``v*^T R v`` of the vectors as given: with ``vector=[0, 0, 2]`` and a target of
1 solve_ik converged (SOLVED) to a frame tilted by 60 degrees from the reference. Reference:
the angle between the frame's axis (Pinocchio's forward kinematics) and the world vector.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace import features as F
from taskspace.ik import solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot


def _rotation(robot: Robot, q: np.ndarray, frame: str) -> np.ndarray:
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return np.asarray(data.oMf[model.getFrameId(frame)].rotation)


def test_alignment_value_is_the_cosine_of_the_angle() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    feature = F.Alignment(robot, ee, [0.0, 0.0, 2.0], [0.0, 3.0, 4.0])
    for q in (robot.q_default, robot.q_default + 0.3):
        axis = _rotation(robot, q, ee)[:, 2]
        expected = axis @ np.array([0.0, 0.6, 0.8])
        assert abs(feature.value(robot.state(q))[0] - expected) < 1e-12


def test_solve_ik_aligns_with_non_unit_vectors() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    task = Task(F.Alignment(robot, ee, [0.0, 0.0, 2.0], [0.0, 0.0, -5.0]), [1.0])
    result = solve_ik(robot, [task])
    assert result.success
    axis = _rotation(robot, result.q, ee)[:, 2]
    assert np.degrees(np.arccos(np.clip(-axis[2], -1.0, 1.0))) < 0.5  # hand z points down


def test_relative_alignment_value_is_the_cosine_of_the_angle() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    feature = F.RelativeAlignment(robot, ee, [3.0, 0.0, 0.0], "panda_link3", [0.0, 0.0, 0.5])
    q = robot.q_default + 0.2
    u = _rotation(robot, q, ee)[:, 0]
    w = _rotation(robot, q, "panda_link3")[:, 2]
    assert abs(feature.value(robot.state(q))[0] - u @ w) < 1e-12


def test_huge_vectors_are_normalized_without_overflow() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    feature = F.Alignment(robot, ee, [1e300, 0.0, 0.0], [0.0, 0.0, 1e-6])
    assert np.allclose(feature.vector, [1.0, 0.0, 0.0])
    assert np.allclose(feature.reference, [0.0, 0.0, 1.0])
    assert abs(feature.value(robot.state(robot.q_default))[0]) <= 1.0
