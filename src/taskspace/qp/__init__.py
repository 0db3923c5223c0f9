"""Quadratic programs: data, a persistent solver (proxsuite + others), strict hierarchies."""

from taskspace.qp.closed_form import (
    damped_pseudo_inverse,
    hierarchical_step_exact,
    hierarchical_step_regularized,
    ik_step,
    nullspace_projector,
    pseudo_inverse,
    stacked_step,
    weighted_pseudo_inverse,
    weighted_pseudo_inverse_woodbury,
)
from taskspace.qp.conflict import conflicting_blocks
from taskspace.qp.hierarchy import (
    HierarchyLevel,
    HierarchyOptions,
    HierarchyResult,
    HierarchySolver,
)
from taskspace.qp.kkt import KKTResiduals, kkt_residuals
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus
from taskspace.qp.rows import (
    InequalityStack,
    TaskRowStack,
    WeightedQPBuilder,
    combine_bounds,
    combine_boxes,
)
from taskspace.qp.solver import (
    BACKENDS,
    QPSolver,
    QPSolverOptions,
    available_backends,
    unconstrained_minimizer,
)

__all__ = [
    "BACKENDS",
    "INF",
    "HierarchyLevel",
    "HierarchyOptions",
    "HierarchyResult",
    "HierarchySolver",
    "InequalityStack",
    "KKTResiduals",
    "QPProblem",
    "QPResult",
    "QPSolver",
    "QPSolverOptions",
    "QPStatus",
    "RowBlock",
    "TaskRowStack",
    "WeightedQPBuilder",
    "available_backends",
    "combine_bounds",
    "combine_boxes",
    "conflicting_blocks",
    "damped_pseudo_inverse",
    "hierarchical_step_exact",
    "hierarchical_step_regularized",
    "ik_step",
    "kkt_residuals",
    "nullspace_projector",
    "pseudo_inverse",
    "stacked_step",
    "unconstrained_minimizer",
    "weighted_pseudo_inverse",
    "weighted_pseudo_inverse_woodbury",
]
