"""Inverse kinematics: weighted and hierarchical differential IK, Gauss-Newton, interpolation."""

from taskspace.ik.differential_ik import (
    DifferentialIK,
    DifferentialIKOptions,
    IKStatus,
    IKStepResult,
)
from taskspace.ik.feature_goal_region import FeatureGoalRegion
from taskspace.ik.hierarchical_ik import HierarchicalIK, HierarchicalIKResult
from taskspace.ik.interpolation import (
    InterpolationResult,
    joint_space_interpolation,
    task_space_interpolation,
)
from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.ik.solve_ik import SolveIKOptions, SolveIKResult, SolveIKStatus, solve_ik
from taskspace.qp.rows import combine_bounds

__all__ = [
    "DifferentialIK",
    "DifferentialIKOptions",
    "FeatureGoalRegion",
    "HierarchicalIK",
    "HierarchicalIKResult",
    "IKStatus",
    "IKStepResult",
    "InterpolationResult",
    "PoseGoalRegion",
    "SolveIKOptions",
    "SolveIKResult",
    "SolveIKStatus",
    "combine_bounds",
    "joint_space_interpolation",
    "solve_ik",
    "task_space_interpolation",
]
