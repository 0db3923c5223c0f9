"""Grasping: contact models, grasp matrix, force and form closure, quality, contact forces."""

from taskspace.grasping.closure import (
    ClosureResult,
    closure_hull,
    closure_lp,
    force_closure,
    form_closure,
)
from taskspace.grasping.contact import (
    ContactType,
    GraspContact,
    contact_edges,
    contact_frame,
    grasp_radius,
    primitive_wrenches,
)
from taskspace.grasping.contact_forces import ContactForces, balance_forces
from taskspace.grasping.grasp_matrix import grasp_matrix, hand_jacobian
from taskspace.grasping.quality import (
    GraspQuality,
    epsilon_l1,
    epsilon_linf,
    grasp_quality,
    minimal_closure_subset,
    task_wrench_scale,
    wrench_space_l1,
    wrench_space_linf,
)

__all__ = [
    "ClosureResult",
    "ContactForces",
    "ContactType",
    "GraspContact",
    "GraspQuality",
    "balance_forces",
    "closure_hull",
    "closure_lp",
    "contact_edges",
    "contact_frame",
    "epsilon_l1",
    "epsilon_linf",
    "force_closure",
    "form_closure",
    "grasp_matrix",
    "grasp_quality",
    "grasp_radius",
    "hand_jacobian",
    "minimal_closure_subset",
    "primitive_wrenches",
    "task_wrench_scale",
    "wrench_space_l1",
    "wrench_space_linf",
]
