"""Robot models: ``Robot``, ``State``, obstacle ``World`` and the robot registry.

The names are imported on first use (PEP 562), so that ``taskspace robots`` can read the
registry without importing Pinocchio and coal.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# The registry is light (no Pinocchio): imported now, so that the function ``registry``, not
# the submodule of the same name, is the package attribute.
from taskspace.model.registry import RobotSpec, available_robots, registry, robot_spec

if TYPE_CHECKING:
    from taskspace.model.robot import (
        CollisionPruningOptions,
        PrunedCollisionPairs,
        Robot,
        configuration_from_joint_values,
        prune_collision_pairs,
    )
    from taskspace.model.state import State
    from taskspace.model.versioning import ModelFollower
    from taskspace.model.world import Obstacle, World, as_se3

_SOURCES = {
    "CollisionPruningOptions": "robot",
    "ModelFollower": "versioning",
    "PrunedCollisionPairs": "robot",
    "Robot": "robot",
    "configuration_from_joint_values": "robot",
    "prune_collision_pairs": "robot",
    "State": "state",
    "Obstacle": "world",
    "World": "world",
    "as_se3": "world",
}

__all__ = [
    "CollisionPruningOptions",
    "ModelFollower",
    "Obstacle",
    "PrunedCollisionPairs",
    "Robot",
    "RobotSpec",
    "State",
    "World",
    "as_se3",
    "available_robots",
    "configuration_from_joint_values",
    "prune_collision_pairs",
    "registry",
    "robot_spec",
]


def __getattr__(name: str) -> Any:
    if name in _SOURCES:
        module = importlib.import_module(f"taskspace.model.{_SOURCES[name]}")
        value = getattr(module, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'taskspace.model' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted([*globals(), *_SOURCES])
