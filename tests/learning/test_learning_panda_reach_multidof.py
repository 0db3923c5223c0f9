"""PandaReach refuses a robot whose joints are not 7 one-dof joints (a free-flyer base).

The envs checked only ``nq == 7`` and the frame ``panda_hand_tcp``: the Panda's URDF on a
free-flyer with its arm joints locked has both (the free-flyer alone has ``nq = 7``, ``nv =
6``). Its infinite base velocity limits were then named by velocity index in
``robot.joint_names`` (one joint): a bare IndexError; with finite limits the update ``q + dt
a v_max`` mixed a quaternion with a 6-vector. The reference is Pinocchio's own joint table.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import example_robot_data
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning.envs import PandaReachEnv
from taskspace.learning.envs.panda_reach import PandaReachVectorEnv
from taskspace.model.robot import Robot


@pytest.fixture(scope="module")
def floating_panda() -> Robot:
    robots = Path(example_robot_data.getModelPath("panda_description/urdf/panda.urdf"))
    urdf = robots / "panda_description" / "urdf" / "panda.urdf"
    locked = [f"panda_joint{i}" for i in range(1, 8)]
    locked += ["panda_finger_joint1", "panda_finger_joint2"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.from_urdf(
            urdf, free_flyer=True, locked_joints=locked, package_dirs=[str(robots.parent.parent)]
        )


@pytest.mark.parametrize("vector", [False, True])
def test_free_flyer_with_seven_coordinates_is_refused_naming_the_joint(
    floating_panda: Robot, vector: bool
) -> None:
    model = floating_panda._model
    # Pinocchio's table: one joint of 7 coordinates and 6 velocities, the frame is there
    assert model.njoints == 2 and (model.joints[1].nq, model.joints[1].nv) == (7, 6)
    assert floating_panda.nq == 7 and "panda_hand_tcp" in floating_panda.frame_names
    name = model.names[1]
    with pytest.raises(InvalidInputError, match=rf"{name} \(nq=7, nv=6\)"):
        if vector:
            PandaReachVectorEnv(2, robot=floating_panda)
        else:
            PandaReachEnv(robot=floating_panda)


def test_not_a_robot_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="taskspace Robot"):
        PandaReachEnv(robot="panda")  # type: ignore[arg-type]


def test_velocity_coordinate_names_follow_idx_v(floating_panda: Robot) -> None:
    # the names of unlimited velocity coordinates come from Pinocchio's idx_v and nv (the
    # free-flyer's 6 coordinates are all 'root_joint'; robot.joint_names has one entry)
    from taskspace.learning.envs.panda_reach import _velocity_joint_names

    for robot in (floating_panda, Robot.load("panda")):
        model = robot._model
        expected = [
            model.names[j] for j in range(1, model.njoints) for _ in range(model.joints[j].nv)
        ]
        assert _velocity_joint_names(robot) == expected
