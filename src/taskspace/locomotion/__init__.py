"""Legged locomotion: support polygons, ZMP, LIPM preview control, footsteps, gaits, hopper."""

from taskspace.locomotion.compass_gait import (
    CompassGait,
    LimitCycle,
    LimitCycleOptions,
    StepResult,
    find_limit_cycle,
    return_map,
    simulate_step,
)
from taskspace.locomotion.foot import FOOT_ROBOTS, ContactKind, FootGeometry, robot_feet
from taskspace.locomotion.footsteps import (
    Footstep,
    FootstepPlan,
    Phase,
    PhaseKind,
    StepTiming,
    arc_walk,
    footsteps_along_poses,
    straight_walk,
    turn_in_place,
)
from taskspace.locomotion.kneed_walker import (
    KneedStepResult,
    KneedWalker,
    find_kneed_limit_cycle,
    kneed_return_map,
    simulate_kneed_step,
)
from taskspace.locomotion.lipm import CartTable, LipmTrajectory
from taskspace.locomotion.preview_control import (
    PreviewController,
    PreviewOptions,
    WalkingPattern,
    preview_walking_pattern,
)
from taskspace.locomotion.quadruped_trot import TrotOptions, TrotResult, trot
from taskspace.locomotion.raibert_hopper import (
    HopperParameters,
    HopperResult,
    RaibertOptions,
    simulate_hopper,
)
from taskspace.locomotion.support_polygon import (
    StaticStability,
    SupportPolygon,
    static_stability,
    support_polygon,
)
from taskspace.locomotion.swing_trajectory import SwingSample, SwingTrajectory
from taskspace.locomotion.whole_body_walking import (
    WalkingOptions,
    WalkingReference,
    WalkingResult,
    plan_from_robot,
    walk,
    walking_reference,
)
from taskspace.locomotion.zmp import (
    ContactWrench,
    center_of_pressure,
    contact_wrench_from_dynamics,
    total_wrench,
    zmp_from_dynamics,
    zmp_from_wrenches,
)
from taskspace.locomotion.zmp_mpc import ZmpMpc, ZmpMpcOptions, ZmpMpcResult, mpc_walking_pattern
from taskspace.locomotion.zmp_reference import (
    SoleSize,
    support_polygon_at,
    support_polygons,
    zmp_reference,
)

__all__ = [
    "FOOT_ROBOTS",
    "CartTable",
    "CompassGait",
    "ContactKind",
    "ContactWrench",
    "FootGeometry",
    "Footstep",
    "FootstepPlan",
    "HopperParameters",
    "HopperResult",
    "KneedStepResult",
    "KneedWalker",
    "LimitCycle",
    "LimitCycleOptions",
    "LipmTrajectory",
    "Phase",
    "PhaseKind",
    "PreviewController",
    "PreviewOptions",
    "RaibertOptions",
    "SoleSize",
    "StaticStability",
    "StepResult",
    "StepTiming",
    "SupportPolygon",
    "SwingSample",
    "SwingTrajectory",
    "TrotOptions",
    "TrotResult",
    "WalkingOptions",
    "WalkingPattern",
    "WalkingReference",
    "WalkingResult",
    "ZmpMpc",
    "ZmpMpcOptions",
    "ZmpMpcResult",
    "arc_walk",
    "center_of_pressure",
    "contact_wrench_from_dynamics",
    "find_kneed_limit_cycle",
    "find_limit_cycle",
    "footsteps_along_poses",
    "kneed_return_map",
    "mpc_walking_pattern",
    "plan_from_robot",
    "preview_walking_pattern",
    "return_map",
    "robot_feet",
    "simulate_hopper",
    "simulate_kneed_step",
    "simulate_step",
    "static_stability",
    "straight_walk",
    "support_polygon",
    "support_polygon_at",
    "support_polygons",
    "total_wrench",
    "trot",
    "turn_in_place",
    "walk",
    "walking_reference",
    "zmp_from_dynamics",
    "zmp_from_wrenches",
    "zmp_reference",
]
