"""taskspace: the algorithms of an introductory robotics course on real robot models."""

from taskspace.errors import (
    ConcurrentUseError,
    InfeasibleError,
    InvalidInputError,
    LimitError,
    MissingDependencyError,
    ModelLoadError,
    NotFiniteError,
    PlanningError,
    ShapeError,
    SolverError,
    StaleModelError,
    TaskspaceError,
    TaskspaceWarning,
    UnknownNameError,
)

__version__ = "0.2.0.dev0"

__all__ = [
    "ConcurrentUseError",
    "InfeasibleError",
    "InvalidInputError",
    "LimitError",
    "MissingDependencyError",
    "ModelLoadError",
    "NotFiniteError",
    "PlanningError",
    "ShapeError",
    "SolverError",
    "StaleModelError",
    "TaskspaceError",
    "TaskspaceWarning",
    "UnknownNameError",
    "__version__",
]
