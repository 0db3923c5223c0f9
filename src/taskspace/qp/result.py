"""QP results."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from taskspace._validation import FloatArray


class QPStatus(enum.Enum):
    """Outcome of a QP solve."""

    SOLVED = "solved"
    """Optimal within tolerance."""
    UNCONSTRAINED = "unconstrained"
    """The unconstrained minimizer already satisfied every constraint (no QP iteration)."""
    RELAXED = "relaxed"
    """The constraints conflict; ``x`` is the least-violating solution (see ``culprits``)."""
    MAX_ITERATIONS = "max_iterations"
    """The backend stopped at its iteration limit; ``x`` is its last iterate."""
    FAILED = "failed"
    """The backend failed."""


@dataclass
class QPResult:
    """Result of a QP solve.

    Attributes:
        success: ``x`` is optimal for the problem as posed.
        status: see :class:`QPStatus`.
        x: solution (always set; the least-violating point when relaxed).
        objective: ``1/2 x'Hx + g'x``.
        iterations: backend iterations (0 for the unconstrained shortcut).
        solve_time: wall time of the solve [s].
        backend: name of the backend that produced ``x``.
        culprits: constraint blocks violated by the least-violating solution (when relaxed).
        violations: largest violation per constraint block.
    """

    success: bool
    status: QPStatus
    x: FloatArray
    objective: float
    iterations: int = 0
    solve_time: float = 0.0
    backend: str = ""
    culprits: list[str] = field(default_factory=list)
    violations: dict[str, float] = field(default_factory=dict)

    @staticmethod
    def failed(n: int, backend: str, solve_time: float) -> QPResult:
        """A failure result with a zero vector."""
        return QPResult(False, QPStatus.FAILED, np.zeros(n), float("nan"), 0, solve_time, backend)
