"""task_space_interpolation on features whose values are not vectors (audit5).

Targets were interpolated on a straight line unless the feature was a FramePose: between two
orientations the middle targets were not rotations ("target ... is not a rotation matrix"
raised in the middle of the motion), between two configurations of a robot with continuous
joints the (cos, sin) pairs were not unit ("must have unit norm"), and a relative pose was
interpolated as a 4x4 matrix. References: Pinocchio's forward kinematics and Lie-group
functions (log3, difference).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.errors import InvalidInputError
from taskspace.ik import joint_space_interpolation, task_space_interpolation
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot


def _placement(robot: Robot, q: np.ndarray, frame: str) -> pin.SE3:
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId(frame)].copy()


def test_orientation_targets_follow_the_geodesic() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    q0 = robot.q_default
    R0 = _placement(robot, q0, ee).rotation
    RT = pin.exp3(np.array([0.0, 0.0, 2.5])) @ R0
    result = task_space_interpolation(robot, Task(F.Orientation(robot, ee)), RT, q0, 20)
    assert result.success
    assert result.task_targets is not None
    angles = []
    for R in result.task_targets:
        R = np.asarray(R)
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-12) and np.linalg.det(R) > 0
        angles.append(np.linalg.norm(pin.log3(R0.T @ R)))
    assert np.all(np.diff(angles) >= -1e-12) and abs(angles[-1] - 2.5) < 1e-12
    final = _placement(robot, result.q[-1], ee).rotation
    assert np.linalg.norm(pin.log3(RT.T @ final)) < 1e-3


def test_relative_pose_targets_are_rigid_motions() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    q0 = robot.q_default
    qT = q0.copy()
    qT[3:7] += [0.2, -0.3, 0.25, 0.4]  # the joints between panda_link3 and the hand
    feature = F.RelativeFramePose(robot, ee, "panda_link3")
    target = _placement(robot, qT, "panda_link3").actInv(_placement(robot, qT, ee))
    result = task_space_interpolation(robot, Task(feature), target, q0, 20)
    assert result.success
    reached = _placement(robot, result.q[-1], "panda_link3").actInv(
        _placement(robot, result.q[-1], ee)
    )
    assert np.linalg.norm(pin.log6(target.actInv(reached)).vector) < 1e-3


def test_configuration_targets_stay_on_the_manifold_of_continuous_joints() -> None:
    with pytest.warns(Warning):  # kinova's SRDF leaves colliding pairs (a ModelWarning)
        robot = Robot.load("kinova")
    model = robot.model
    q0 = robot.q_default
    qT = pin.integrate(model, q0, np.array([2.0, 0.1, 0.0, 0.0, 0.0, -0.5]))
    result = task_space_interpolation(robot, Task(F.JointConfiguration(robot)), qT, q0, 10)
    assert result.success
    assert result.task_targets is not None
    for q in result.task_targets:
        assert np.allclose(pin.normalize(model, np.asarray(q)), q, atol=1e-12)
    assert np.abs(pin.difference(model, qT, result.q[-1])).max() < 1e-3


@pytest.mark.parametrize("steps", [2.5, True, float("inf"), 0])
def test_steps_must_be_a_positive_integer(steps: object) -> None:
    # 2.5 and inf raised a bare TypeError from range(); True ran one step
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    task = Task(F.Position(robot, ee), [0.3, 0.2, 0.5])
    with pytest.raises(InvalidInputError, match="steps must be an integer"):
        task_space_interpolation(robot, task, [0.3, 0.2, 0.5], robot.q_default, steps)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="steps must be an integer"):
        joint_space_interpolation(robot, [task], robot.q_default, steps)  # type: ignore[arg-type]
