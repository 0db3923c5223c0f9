"""Shared settings and robots of the short G1 walks in the walking tests."""

from __future__ import annotations

import pinocchio as pin

from taskspace.locomotion.footsteps import StepTiming
from taskspace.model import Robot

# phases short enough for a 2-3 step walk to simulate in a few seconds
SHORT_TIMING = StepTiming(
    single_support=0.5,
    double_support=0.2,
    initial_double_support=0.6,
    final_double_support=0.8,
    weight_shift=0.3,
)
G1_FEET = ("left_ankle_roll_link", "right_ankle_roll_link")


def turned(g1: Robot, yaw: float) -> Robot:
    """G1 whose default posture faces ``yaw`` (its base turned about the vertical)."""
    q = g1.q_default.copy()
    base = pin.XYZQUATToSE3(q[:7])
    base.rotation = pin.rpy.rpyToMatrix(0.0, 0.0, yaw) @ base.rotation
    q[:7] = pin.SE3ToXYZQUAT(base)
    return Robot(
        g1.model,
        g1.collision_model,
        g1.visual_model,
        name="g1_turned",
        end_effectors=g1.end_effectors,
        default_configuration=q,
    )
