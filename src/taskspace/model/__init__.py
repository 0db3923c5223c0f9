"""Robot models: ``Robot``, ``State``, obstacle ``World`` and the robot registry."""

from taskspace.model.registry import RobotSpec, registry, robot_spec
from taskspace.model.robot import Robot, configuration_from_joint_values
from taskspace.model.state import State
from taskspace.model.world import Obstacle, World, as_se3

__all__ = [
    "Obstacle",
    "Robot",
    "RobotSpec",
    "State",
    "World",
    "as_se3",
    "configuration_from_joint_values",
    "registry",
    "robot_spec",
]
