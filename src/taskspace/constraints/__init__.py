"""Constraints on differential steps: joint limits, collision avoidance, feature bounds."""

from taskspace.constraints.collision_avoidance import CollisionAvoidance
from taskspace.constraints.constraint import Constraint
from taskspace.constraints.contact import Contact, Contact6D, PointContact
from taskspace.constraints.feature_bounds import FeatureBounds
from taskspace.constraints.joint_limits import (
    JointAccelerationLimits,
    JointPositionLimits,
    JointVelocityLimits,
)

__all__ = [
    "CollisionAvoidance",
    "Constraint",
    "Contact",
    "Contact6D",
    "FeatureBounds",
    "JointAccelerationLimits",
    "JointPositionLimits",
    "JointVelocityLimits",
    "PointContact",
]
