"""Every error path of tasks, constraints and IK, with the message text asserted."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from taskspace.constraints import (
    CollisionAvoidance,
    FeatureBounds,
    JointAccelerationLimits,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.errors import InvalidInputError, ShapeError, UnknownNameError
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Position
from taskspace.ik import (
    DifferentialIK,
    DifferentialIKOptions,
    HierarchicalIK,
    joint_space_interpolation,
    task_space_interpolation,
)
from taskspace.model import Robot
from taskspace.tasks import Task

TCP = "panda_hand_tcp"


# ---------------------------------------------------------------------- Task
@pytest.mark.parametrize("gain", [0.0, -0.5, 1.5])
def test_task_gain_outside_unit_interval(panda: Robot, gain: float) -> None:
    with pytest.raises(InvalidInputError) as info:
        Task(Position(panda, TCP), gain=gain, name="reach")
    assert str(info.value) == f"gain of task 'reach' must be in (0, 1], got {gain}"


def test_task_negative_scalar_weight(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        Task(Position(panda, TCP), weight=-1.0)
    assert str(info.value) == (
        f"weight of task 'position({TCP})' must be finite and >= 0, got -1.0"
    )


def test_task_non_finite_weight(panda: Robot) -> None:
    with pytest.raises(InvalidInputError, match="must be finite and >= 0, got inf"):
        Task(Position(panda, TCP), weight=np.inf)


def test_task_negative_vector_weight(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        Task(Position(panda, TCP), weight=np.array([1.0, -1.0, 1.0]), name="reach")
    assert str(info.value) == "weight of task 'reach' must be >= 0"


def test_task_vector_weight_wrong_size(panda: Robot) -> None:
    with pytest.raises(ShapeError) as info:
        Task(Position(panda, TCP), weight=np.array([1.0, 1.0]), name="reach")
    assert str(info.value) == "weight of task 'reach' must have shape (3,), got (2,)"


def test_task_negative_priority(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        Task(Position(panda, TCP), priority=-1, name="reach")
    assert str(info.value) == "priority of task 'reach' must be >= 0"


def test_task_wrong_target_shape(panda: Robot) -> None:
    with pytest.raises(ShapeError) as info:
        Task(Position(panda, TCP), [0.1, 0.2])
    assert str(info.value) == (
        f"target of feature 'position({TCP})' must have shape (3,), got (2,)"
    )
    task = Task(CenterOfMass(panda))
    with pytest.raises(ShapeError, match=r"must have shape \(3,\), got \(4,\)"):
        task.set_target(np.zeros(4))


def test_task_non_finite_target(panda: Robot) -> None:
    with pytest.raises(
        InvalidInputError, match=r"non-finite \(NaN or inf\) entries at indices \[1\]"
    ):
        Task(Position(panda, TCP), [0.1, np.nan, 0.3])


def test_pose_task_bad_target(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        Task(FramePose(panda, TCP), np.zeros(5))
    assert str(info.value) == (
        f"target of feature 'pose({TCP})' must be a pin.SE3, a 4x4 matrix, [x, y, z] or "
        "[x, y, z, qx, qy, qz, qw]; got an array of shape (5,)"
    )
    with pytest.raises(InvalidInputError, match=r"quaternion .* must have unit norm, got 2"):
        Task(FramePose(panda, TCP), [0, 0, 0, 0, 0, 0, 2.0])


def test_posture_target_wrong_size(panda: Robot) -> None:
    with pytest.raises(ShapeError, match=r"must have shape \(7,\), got \(3,\)"):
        Task(JointConfiguration(panda), np.zeros(3))


def test_task_without_target(panda: Robot) -> None:
    task = Task(Position(panda, TCP), name="reach")
    message = (
        "task 'reach' has no target: call task.set_target(...) or task.set_target_from_state(state)"
    )
    with pytest.raises(InvalidInputError) as info:
        task.error(panda.state())
    assert str(info.value) == message
    ik = DifferentialIK(panda, [task])
    with pytest.raises(InvalidInputError) as info:
        ik.solve(panda.state(), 0.01)
    assert str(info.value) == message


def test_task_state_of_other_robot(panda: Robot, robot_loader: Callable[..., Robot]) -> None:
    ur5 = robot_loader("ur5")
    task = Task(CenterOfMass(panda), [0.0, 0.0, 0.5])
    with pytest.raises(InvalidInputError) as info:
        task.error(ur5.state())
    assert str(info.value) == (
        "feature 'center_of_mass' is defined on robot 'panda' but the state belongs to robot 'ur5'"
    )


# ---------------------------------------------------------------------- constraints
def test_joint_position_limits_margin(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        JointPositionLimits(panda, margin=-0.1)
    assert str(info.value) == "margin must be finite and >= 0, got -0.1"
    with pytest.raises(InvalidInputError) as info:
        JointPositionLimits(panda, margin=3.0)
    assert str(info.value) == "margin 3.0 is larger than half a joint range of robot 'panda'"


def test_joint_velocity_limits_errors(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        JointVelocityLimits(panda, limits=[1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0])
    assert str(info.value).startswith("velocity limits must be > 0")
    with pytest.raises(InvalidInputError) as info:
        JointVelocityLimits(panda, scale=0.0)
    assert str(info.value) == "scale must be finite and > 0, got 0.0"
    with pytest.raises(ShapeError, match=r"limits must have shape \(7,\), got \(2,\)"):
        JointVelocityLimits(panda, limits=[1.0, 1.0])


def test_joint_acceleration_limits_errors(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        JointAccelerationLimits(panda, -np.ones(7))
    assert str(info.value) == "acceleration limits must be > 0"


def test_collision_avoidance_errors(robot_loader: Callable[..., Robot]) -> None:
    robot = robot_loader("panda", True)
    with pytest.raises(InvalidInputError) as info:
        CollisionAvoidance(robot, safety_distance=0.1, influence_distance=0.1)
    assert str(info.value) == "influence_distance must be larger than safety_distance"
    with pytest.raises(InvalidInputError) as info:
        CollisionAvoidance(robot, safety_distance=0.2, influence_distance=0.1)
    assert str(info.value) == "influence_distance must be larger than safety_distance"
    with pytest.raises(InvalidInputError) as info:
        CollisionAvoidance(robot, gain=1.5)
    assert str(info.value) == "gain must be in (0, 1], got 1.5"
    with pytest.raises(InvalidInputError) as info:
        CollisionAvoidance(robot, safety_distance=-0.01)
    assert str(info.value) == "safety_distance must be finite and >= 0, got -0.01"
    with pytest.raises(InvalidInputError) as info:
        CollisionAvoidance(robot, influence_distance=0.0)
    assert str(info.value) == "influence_distance must be finite and > 0, got 0.0"
    with pytest.raises(UnknownNameError) as unknown:
        CollisionAvoidance(robot, pairs=[("panda_link0_0", "nothing")])
    assert str(unknown.value).startswith(
        "unknown collision pair 'panda_link0_0|nothing'; valid collision pairs are: "
    )


def test_feature_bounds_errors(panda: Robot) -> None:
    com = CenterOfMass(panda)
    with pytest.raises(InvalidInputError) as info:
        FeatureBounds(com, [0.0, 0.0, 1.0], [1.0, 1.0, 0.5])
    assert str(info.value) == "bounds on center_of_mass: lower > upper"
    with pytest.raises(InvalidInputError) as info:
        FeatureBounds(com, -1.0, 1.0, gain=0.0)
    assert str(info.value) == "gain must be in (0, 1], got 0.0"
    with pytest.raises(ShapeError, match=r"lower must have shape \(3,\), got \(2,\)"):
        FeatureBounds(com, [0.0, 0.0], 1.0)


# ---------------------------------------------------------------------- IK
def test_differential_ik_robot_mismatch(panda: Robot, robot_loader: Callable[..., Robot]) -> None:
    ur5 = robot_loader("ur5")
    reach = Task(Position(ur5, "tool0"), [0.3, 0.0, 0.3], name="ur5 reach")
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(panda, [reach])
    assert str(info.value) == "task 'ur5 reach' is defined on another robot"
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(panda, [Task(Position(panda, TCP))], equality_tasks=[reach])
    assert str(info.value) == "task 'ur5 reach' is defined on another robot"
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(panda, [Task(Position(panda, TCP))], [JointPositionLimits(ur5)])
    assert str(info.value) == "constraint 'joint position limits' is defined on another robot"


def test_differential_ik_needs_a_task(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(panda, [])
    assert str(info.value) == "DifferentialIK needs at least one task"


def test_differential_ik_negative_damping(panda: Robot) -> None:
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(
            panda, [Task(Position(panda, TCP))], options=DifferentialIKOptions(damping=-1.0)
        )
    assert str(info.value) == "damping must be finite and >= 0, got -1.0"


@pytest.mark.parametrize("dt", [0.0, -0.01, float("nan")])
def test_ik_dt_must_be_positive(panda: Robot, dt: float) -> None:
    task = Task(Position(panda, TCP))
    task.set_target_from_state(panda.state())
    with pytest.raises(InvalidInputError) as info:
        DifferentialIK(panda, [task]).solve(panda.state(), dt)
    assert str(info.value) == f"dt must be finite and > 0, got {dt!r}"
    with pytest.raises(InvalidInputError) as info:
        HierarchicalIK(panda, [[task]]).solve(panda.state(), dt)
    assert str(info.value) == f"dt must be finite and > 0, got {dt!r}"


def test_hierarchical_ik_errors(panda: Robot, robot_loader: Callable[..., Robot]) -> None:
    with pytest.raises(InvalidInputError) as info:
        HierarchicalIK(panda, [])
    assert str(info.value) == "HierarchicalIK needs at least one level"
    ur5 = robot_loader("ur5")
    with pytest.raises(InvalidInputError) as info:
        HierarchicalIK(panda, [[Task(Position(ur5, "tool0"), name="other")]])
    assert str(info.value) == "'other' is defined on another robot"
    with pytest.raises(InvalidInputError) as info:
        HierarchicalIK(panda, [[JointPositionLimits(panda)]])
    assert str(info.value) == (
        "'joint position limits' is a box constraint: pass it in `constraints` (boxes bind "
        "every level)"
    )


def test_interpolation_steps_must_be_positive(panda: Robot) -> None:
    task = Task(Position(panda, TCP))
    with pytest.raises(InvalidInputError) as info:
        task_space_interpolation(panda, task, [0.3, 0.0, 0.5], panda.q_default, 0)
    assert str(info.value) == "steps must be an integer >= 1, got 0"
    with pytest.raises(InvalidInputError) as info:
        joint_space_interpolation(panda, [task], panda.q_default, -2)
    assert str(info.value) == "steps must be an integer >= 1, got -2"
