"""Task variables (features) of the lecture notes: value, Jacobian and drift."""

from taskspace.features.alignment import Alignment
from taskspace.features.angular_momentum import AngularMomentum
from taskspace.features.center_of_mass import CenterOfMass
from taskspace.features.collision import CollisionDistance, CollisionPenetration
from taskspace.features.damping import Damping
from taskspace.features.feature import Feature
from taskspace.features.frame_pose import FramePose
from taskspace.features.joint_configuration import JointConfiguration
from taskspace.features.joint_limits import JointLimitPenetration
from taskspace.features.orientation import Orientation
from taskspace.features.position import Position
from taskspace.features.relative_alignment import RelativeAlignment
from taskspace.features.relative_frame_pose import RelativeFramePose
from taskspace.features.relative_position import RelativePosition
from taskspace.features.relative_vector import RelativeVector
from taskspace.features.vector import Vector

__all__ = [
    "Alignment",
    "AngularMomentum",
    "CenterOfMass",
    "CollisionDistance",
    "CollisionPenetration",
    "Damping",
    "Feature",
    "FramePose",
    "JointConfiguration",
    "JointLimitPenetration",
    "Orientation",
    "Position",
    "RelativeAlignment",
    "RelativeFramePose",
    "RelativePosition",
    "RelativeVector",
    "Vector",
]
