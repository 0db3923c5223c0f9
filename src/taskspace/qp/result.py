"""QP results.

Thread safety: :class:`QPStatus` is immutable; a :class:`QPResult` is plain result data (arrays),
not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from taskspace._validation import FloatArray
from taskspace.qp.conflict import conflicting_blocks
from taskspace.qp.kkt import KKTResiduals
from taskspace.qp.problem import QPProblem


class QPStatus(enum.Enum):
    """Outcome of a QP solve."""

    SOLVED = "solved"
    """Optimal: the KKT residuals (``QPResult.kkt``) meet the solver's tolerances."""
    UNCONSTRAINED = "unconstrained"
    """The unconstrained minimizer already satisfied every constraint (no QP iteration)."""
    RELAXED = "relaxed"
    """The constraints conflict; ``x`` is the least-violating solution (see ``culprits``)."""
    INACCURATE = "inaccurate"
    """The backend stopped, but its KKT residuals (``QPResult.kkt``) exceed the tolerances."""
    MAX_ITERATIONS = "max_iterations"
    """The backend stopped at its iteration limit; ``x`` is its last iterate."""
    FAILED = "failed"
    """The backend failed."""


_EMPTY = np.zeros(0)
_EMPTY.setflags(write=False)


def _no_multipliers() -> FloatArray:
    """The default multipliers: one shared, read-only empty array (no allocation per result)."""
    return _EMPTY


@dataclass(slots=True)
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
        culprits: constraint blocks violated by the least-violating solution (when relaxed);
            the penalty spreads a conflict, so blocks dragged along are named too (see
            :attr:`conflict`).
        violations: largest violation per constraint block.
        kkt: KKT residuals of ``(x, y, z, z_box)`` (primal, dual, complementarity, duality
            gap; NaN when not computed).
        y: equality multipliers (n_eq; empty when not computed).
        z: inequality multipliers (n_in).
        z_box: bound multipliers (n).

    Results are made at every control step: the class has ``__slots__`` and multipliers that
    were not computed are one shared read-only empty array.
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
    kkt: KKTResiduals = field(default_factory=KKTResiduals.unknown)
    y: FloatArray = field(default_factory=_no_multipliers)
    z: FloatArray = field(default_factory=_no_multipliers)
    z_box: FloatArray = field(default_factory=_no_multipliers)
    conflict_problem: QPProblem | None = field(default=None, repr=False, compare=False)
    """A copy of a relaxed problem's constraints, for :attr:`conflict` (``None``: not relaxed)."""
    _conflict: list[str] | None = field(default=None, repr=False, compare=False)

    @property
    def conflict(self) -> list[str]:
        """A minimal set of conflicting constraint blocks of a ``RELAXED`` result (else empty).

        The blocks conflict together, and leaving out any one of them makes the rest
        feasible (:func:`~taskspace.qp.conflict.conflicting_blocks`, a deletion filter: one
        feasibility LP per block, computed on first access). The blocks of :attr:`culprits`
        are tried last, so the set lies within them whenever they conflict by themselves.
        """
        if self._conflict is None:
            source = self.conflict_problem
            self._conflict = (
                [] if source is None else conflicting_blocks(source, prefer=self.culprits)
            )
            self.conflict_problem = None
        return list(self._conflict)

    @property
    def primal_residual(self) -> float:
        """Largest constraint violation at ``x``."""
        return self.kkt.primal

    @property
    def dual_residual(self) -> float:
        """Largest stationarity error at ``(x, y, z, z_box)``."""
        return self.kkt.dual

    @property
    def duality_gap(self) -> float:
        """Primal minus dual objective."""
        return self.kkt.duality_gap

    @staticmethod
    def failed(n: int, backend: str, solve_time: float) -> QPResult:
        """A failure result with a zero vector."""
        return QPResult(False, QPStatus.FAILED, np.zeros(n), float("nan"), 0, solve_time, backend)
