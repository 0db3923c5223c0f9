"""Base class of constraints on a differential step ``dq`` (tangent vector, size nv).

Thread safety: a constraint keeps no per-step workspace besides immutable caches replaced at
once (e.g. the velocity box for the last ``dt``), and reads the :class:`~taskspace.model.State`
it is given, so one constraint may serve solvers in several threads. What it derives from the
robot (limits, collision pairs, compiled rows) is rebuilt on the next call after a model or
world change; do not change the robot, the world or the constraint's parameters (bounds, gains,
margins) while another thread steps with it.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from taskspace.features.compiled import CompiledConstraint
    from taskspace.features.rows import Box, InequalityRows
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Constraint(abc.ABC):
    """A constraint on the step ``dq`` taken from ``state`` during ``dt``.

    Subclasses implement :meth:`bounds` (a box ``lb <= dq <= ub``) or :meth:`inequalities`
    (rows ``l <= C dq <= u``) or both; a method that does not apply returns ``None``.

    Attributes:
        name: label used in results and infeasibility diagnoses.
        hard_bounds: whether the box is physical (velocity/acceleration), so that it wins over
            softer boxes (position limits) when the two cannot both hold.
        bounds_read_state: whether :meth:`bounds` reads the state. A class that declares it
            False itself (a subclass does not inherit the declaration) promises that its box
            depends only on ``dt`` and the robot's model version (:attr:`Robot.version`): a
            solver may keep the box while both are unchanged (the compiled IK step does).
    """

    hard_bounds: bool = False
    bounds_read_state: bool = True

    def __init__(self, robot: Robot, name: str) -> None:
        self.robot = robot
        self.name = name

    def bounds(self, state: State, dt: float) -> Box | None:
        """Box ``(lb, ub)`` on ``dq`` or ``None`` (a plain ``(lb, ub)`` tuple is accepted)."""
        return None

    def inequalities(self, state: State, dt: float) -> InequalityRows | None:
        """Rows ``(C, l, u)`` with ``l <= C dq <= u`` or ``None`` (a plain tuple is accepted)."""
        return None

    def compiled_constraint(self) -> CompiledConstraint | None:
        """How a compiled IK kernel evaluates :meth:`inequalities` itself, or ``None``.

        ``None``: the rows are evaluated in Python (:meth:`inequalities`); the compiled
        weighted step still solves them (its general step), the other consumers may take
        their Python path. A constraint class a kernel evaluates overrides this method (see
        :mod:`taskspace.features.compiled`); only a class's own override counts, so a
        subclass that changes the rows is not evaluated by a kernel unless it declares them.
        """
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}('{self.name}')"
