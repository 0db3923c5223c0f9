"""Legged locomotion: support polygons, ZMP, LIPM preview control, footsteps, gaits, hopper."""

from taskspace.locomotion.foot import FOOT_ROBOTS, ContactKind, FootGeometry, robot_feet
from taskspace.locomotion.support_polygon import (
    StaticStability,
    SupportPolygon,
    static_stability,
    support_polygon,
)
from taskspace.locomotion.zmp import (
    ContactWrench,
    center_of_pressure,
    contact_wrench_from_dynamics,
    total_wrench,
    zmp_from_dynamics,
    zmp_from_wrenches,
)

__all__ = [
    "FOOT_ROBOTS",
    "ContactKind",
    "ContactWrench",
    "FootGeometry",
    "StaticStability",
    "SupportPolygon",
    "center_of_pressure",
    "contact_wrench_from_dynamics",
    "robot_feet",
    "static_stability",
    "support_polygon",
    "total_wrench",
    "zmp_from_dynamics",
    "zmp_from_wrenches",
]
