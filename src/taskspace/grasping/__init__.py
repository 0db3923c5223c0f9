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
from taskspace.grasping.epsilon import (
    epsilon_l1_batch,
    epsilon_l1_fast,
    grasp_epsilon_batch,
    primitive_wrenches_batch,
)
from taskspace.grasping.grasp_matrix import grasp_matrix, hand_jacobian
from taskspace.grasping.hand_grasp import (
    Finger,
    Hand,
    HandGrasp,
    StartsInCollisionError,
    close_hand,
    sample_hand_grasps,
)
from taskspace.grasping.multifinger import (
    MultiFingerCandidates,
    MultiFingerOptions,
    sample_multifinger_grasps,
)
from taskspace.grasping.object_mesh import TriangleMesh, box_mesh, cylinder_mesh, sphere_mesh
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
from taskspace.grasping.synthesis import (
    AntipodalOptions,
    GraspCandidates,
    PlacedGrasp,
    grasp_tool_pose,
    place_grasps,
    sample_antipodal_grasps,
)

__all__ = [
    "AntipodalOptions",
    "ClosureResult",
    "ContactForces",
    "ContactType",
    "Finger",
    "GraspCandidates",
    "GraspContact",
    "GraspQuality",
    "Hand",
    "HandGrasp",
    "MultiFingerCandidates",
    "MultiFingerOptions",
    "PlacedGrasp",
    "StartsInCollisionError",
    "TriangleMesh",
    "balance_forces",
    "box_mesh",
    "close_hand",
    "closure_hull",
    "closure_lp",
    "contact_edges",
    "contact_frame",
    "cylinder_mesh",
    "epsilon_l1",
    "epsilon_l1_batch",
    "epsilon_l1_fast",
    "epsilon_linf",
    "force_closure",
    "form_closure",
    "grasp_epsilon_batch",
    "grasp_matrix",
    "grasp_quality",
    "grasp_radius",
    "grasp_tool_pose",
    "hand_jacobian",
    "minimal_closure_subset",
    "place_grasps",
    "primitive_wrenches",
    "primitive_wrenches_batch",
    "sample_antipodal_grasps",
    "sample_hand_grasps",
    "sample_multifinger_grasps",
    "sphere_mesh",
    "task_wrench_scale",
    "wrench_space_l1",
    "wrench_space_linf",
]
