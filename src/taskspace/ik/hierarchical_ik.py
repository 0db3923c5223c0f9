"""Strict task hierarchies for differential IK (slides 2:42-2:44): a cascade of QPs.

Thread safety: :class:`HierarchicalIK` serializes its calls with a lock (see there); a
:class:`HierarchicalIKResult` is plain result data, not locked: do not modify it while another
thread reads it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_positive
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError, SolverError
from taskspace.ik._native_hierarchy import DECLINED, NativeHierarchy
from taskspace.ik._native_hierarchy import supported as native_supported
from taskspace.model.robot import Robot
from taskspace.model.state import State
from taskspace.qp.hierarchy import (
    HierarchyLevel,
    HierarchyOptions,
    HierarchyResult,
    HierarchySolver,
)
from taskspace.qp.problem import RowBlock
from taskspace.qp.result import QPStatus
from taskspace.qp.rows import BoxStack, InequalityStack, TaskRowStack
from taskspace.tasks import Task


@dataclass
class HierarchicalIKResult:
    """Result of one hierarchical step.

    Attributes:
        success: every level was solved.
        dq: the step (tangent vector) [rad, m].
        velocity: ``dq / dt``.
        residuals: per level, the norm of its weighted task residual after the step
            (linearized: ``|J dq + gain e|``).
        violations: per level, the largest violation of its inequalities (linearized).
        hierarchy: the cascade's result (per-level QP results, nullspace dimensions).
        build_time, solve_time: wall times [s].
        native: the compiled step answered (every level in closed form, or its level QPs
            certified when an inequality or bound is active; see ``HierarchicalIK``'s
            ``native`` and ``hierarchy.status``: ``UNCONSTRAINED`` or ``SOLVED``).
        native_declined: why the compiled step declined and the Python cascade answered
            (empty when it answered or did not run).
        culprits: when the step failed, the hard constraints (by name, ``"bounds"`` for the
            box constraints together) its point violates, then the cascade's diagnostics
            (``hierarchy.culprits``); empty on success.
    """

    success: bool
    dq: FloatArray
    velocity: FloatArray
    residuals: list[float]
    violations: list[float]
    hierarchy: HierarchyResult
    build_time: float = 0.0
    solve_time: float = 0.0
    native: bool = False
    native_declined: str = ""
    culprits: list[str] = field(default_factory=list)


_BACKOFF = frozenset(DECLINED[k] for k in (3, 4, 5))
"""Declines after which the next steps skip the kernel (see ``HierarchicalIK``'s ``native``)."""
_BACKOFF_STEPS = 25

MAX_WEIGHTED_RESIDUAL = 1e30
"""Largest norm of a level's weighted task residual that a step accepts (beyond it the QP
cascade loses accuracy and can take minutes)."""
_MAX_SQUARED_RESIDUAL = MAX_WEIGHTED_RESIDUAL**2


def _check_levels(levels: object) -> list[list[Task | Constraint]]:
    """Validate the nested structure ``[[task or constraint, ...], ...]`` of the levels."""
    if isinstance(levels, Sequence) and not isinstance(levels, str) and len(levels) == 0:
        raise InvalidInputError("HierarchicalIK needs at least one level")
    if isinstance(levels, (Task, Constraint, str)) or not isinstance(levels, Sequence):
        raise InvalidInputError(
            "levels must be a non-empty list of levels, each a list of tasks and constraints "
            "(highest priority first), e.g. [[task1], [task2, task3]]; got "
            f"{type(levels).__name__}"
        )
    out: list[list[Task | Constraint]] = []
    for k, level in enumerate(levels):
        if isinstance(level, (Task, Constraint)):
            raise InvalidInputError(
                f"levels[{k}] is a single {type(level).__name__}, not a level: levels are lists "
                "of tasks, e.g. HierarchicalIK(robot, [[task1], [task2]]); "
                "HierarchicalIK.from_priorities(robot, tasks) groups tasks by their priority"
            )
        if not isinstance(level, Sequence) or isinstance(level, str):
            raise InvalidInputError(
                f"levels[{k}] must be a list of tasks and constraints, got {type(level).__name__}"
            )
        for j, item in enumerate(level):
            if not isinstance(item, (Task, Constraint)):
                raise InvalidInputError(
                    f"levels[{k}][{j}] must be a Task or a Constraint, got {type(item).__name__}"
                )
        if not level:
            raise InvalidInputError(f"levels[{k}] is empty: every level needs a task or constraint")
        out.append(list(level))
    return out


def _check_constraints(constraints: object) -> list[Constraint]:
    if isinstance(constraints, Constraint):
        return [constraints]
    if not isinstance(constraints, Sequence) or isinstance(constraints, str):
        raise InvalidInputError(
            f"constraints must be a list of Constraint, got {type(constraints).__name__}"
        )
    for j, c in enumerate(constraints):
        if not isinstance(c, Constraint):
            raise InvalidInputError(
                f"constraints[{j}] must be a Constraint (joint limits, collision avoidance...), "
                f"got {type(c).__name__}"
            )
    return list(constraints)


class HierarchicalIK:
    """Differential IK with strict priorities between levels (any number of levels).

    Level ``k`` is solved subject to every level ``j < k`` held at its optimum; inequality
    constraints placed in a level are minimized in violation at that level and then held.
    ``constraints`` (joint limits...) bind every level.

    Thread safety: the solver keeps its buffers and the cascade's QP workspaces, so the
    calls of several threads run one at a time (a lock); each thread needs its own
    :class:`~taskspace.model.State`, and the tasks must not be changed while another thread
    steps.

    Args:
        robot: the robot.
        levels: highest priority first; each level a list of tasks and constraints.
        constraints: hard constraints for all levels.
        options: cascade settings (damping, rank tolerance, QP solver).
        native: try the compiled step first (``taskspace/_native``; when it is built and
            every task's feature declares a compiled term): one kernel call builds every
            level's rows and runs the equality cascade, and answers when no inequality or
            bound is violated at its point; when one is, it solves the level QPs itself (an
            active-set method, each level's KKT residuals certified to 1e-9). When a level
            is close to rank-deficient or a level QP is not certified, the Python cascade
            answers. The result's ``native`` says which did. After a
            step it declined for an active inequality or bound (its level QPs not
            certified, or turned off), the next steps go to the Python cascade directly
            (``native_declined`` says so) until it finds every inequality and bound inactive
            again, or for at most 25 steps.
    """

    def __init__(
        self,
        robot: Robot,
        levels: Sequence[Sequence[Task | Constraint]],
        constraints: Sequence[Constraint] = (),
        options: HierarchyOptions | None = None,
        *,
        native: bool = True,
    ) -> None:
        self.robot = robot
        self.levels = _check_levels(levels)
        self.constraints = _check_constraints(constraints)
        for level in self.levels:
            for item in level:
                item_robot = item.feature.robot if isinstance(item, Task) else item.robot
                if item_robot is not robot:
                    raise InvalidInputError(f"'{item.name}' is defined on another robot")
                if isinstance(item, Constraint) and item.bounds.__func__ is not Constraint.bounds:  # type: ignore[attr-defined]
                    raise InvalidInputError(
                        f"'{item.name}' is a box constraint: pass it in `constraints` (boxes "
                        "bind every level)"
                    )
        for c in self.constraints:
            if c.robot is not robot:
                raise InvalidInputError(f"constraint '{c.name}' is defined on another robot")
        if options is not None and not isinstance(options, HierarchyOptions):
            raise InvalidInputError(
                f"options must be a HierarchyOptions, got {type(options).__name__}"
            )
        self.solver = HierarchySolver(options)
        # every level's rows are views of one task-row stack (one dot product checks the
        # residuals of all levels); each level's inequality rows have their own stack
        nv = robot.nv
        self._names = [
            f"level {k} ({', '.join(item.name for item in level)})"
            for k, level in enumerate(self.levels)
        ]
        level_tasks = [[t for t in level if isinstance(t, Task)] for level in self.levels]
        self._rows = TaskRowStack([t for tasks in level_tasks for t in tasks], nv)
        self._r_all = self._rows.rhs
        self._J: list[FloatArray] = []
        self._r: list[FloatArray] = []
        start = 0
        for tasks in level_tasks:
            stop = start + sum(t.dim for t in tasks)
            self._J.append(self._rows.J[start:stop])
            self._r.append(self._rows.rhs[start:stop])
            start = stop
        pairs = list(zip(self._rows.tasks, self._rows.slices))
        self._level_pairs: list[list[tuple[Task, slice]]] = []
        for tasks in level_tasks:
            self._level_pairs.append(pairs[: len(tasks)])
            pairs = pairs[len(tasks) :]
        self._level_inequalities = [
            InequalityStack([c for c in level if isinstance(c, Constraint)], nv)
            for level in self.levels
        ]
        self._hard_inequalities = InequalityStack(self.constraints, nv)
        self._boxes = BoxStack(self.constraints, nv)
        self._lock = threading.Lock()
        self._level_tasks = level_tasks
        self._native_option = bool(native)
        self._native: NativeHierarchy | None = None
        self._native_checked = False
        self._native_backoff = 0  # steps that skip the kernel (see _solve)

    @property
    def native(self) -> bool:
        """Whether steps try the compiled closed-form step first (see ``native``)."""
        if not self._native_checked:
            self._native_checked = True
            if self._native_option and native_supported(self._level_tasks):
                self._native = NativeHierarchy(self.robot, self.levels, self.constraints)
        return self._native is not None

    @classmethod
    def from_priorities(
        cls,
        robot: Robot,
        tasks: Sequence[Task],
        constraints: Sequence[Constraint] = (),
        options: HierarchyOptions | None = None,
    ) -> HierarchicalIK:
        """Group ``tasks`` into levels by their ``priority`` (0 first)."""
        if isinstance(tasks, Task) or not isinstance(tasks, Sequence) or not tasks:
            raise InvalidInputError("from_priorities needs a non-empty list of tasks")
        for j, t in enumerate(tasks):
            if not isinstance(t, Task):
                raise InvalidInputError(f"tasks[{j}] must be a Task, got {type(t).__name__}")
        priorities = sorted({t.priority for t in tasks})
        return cls(
            robot,
            [[t for t in tasks if t.priority == p] for p in priorities],
            constraints,
            options,
        )

    def build(self, state: State, dt: float) -> list[HierarchyLevel]:
        """The levels' least-squares rows and inequalities at ``state``.

        The rows ``J`` and ``r`` (and ``C``, ``l``, ``u``) of each level are buffers refilled
        by the next call (copy them to keep them).
        """
        with self._lock:
            return self._build(state, dt)

    def _build(self, state: State, dt: float) -> list[HierarchyLevel]:
        """:meth:`build` without the lock (the caller holds it)."""
        self._rows.velocity(state)
        out = []
        for k, stack in enumerate(self._level_inequalities):
            J, r = self._J[k], self._r[k]
            damping = self._level_damping(k)
            if stack:
                (C, l, u), blocks = stack.fill(state, dt)
                if blocks:
                    out.append(HierarchyLevel(self._names[k], J, r, C, l, u, damping))
                    continue
            out.append(HierarchyLevel(self._names[k], J, r, damping=damping))
        return out

    def _level_damping(self, k: int) -> float | None:
        """Level ``k``'s damping with its tasks' Levenberg-Marquardt terms (``None``: none).

        ``mu + sum_i lm_damping_i |sqrt(rho_i) e_i|^2`` over the level's tasks, ``e_i`` read
        from the stacked rows ``-gain_i sqrt(rho_i) e_i``.
        """
        extra = 0.0
        r_all = self._r_all
        for task, rows in self._level_pairs[k]:
            if task.lm_damping:
                ri = r_all[rows]
                extra += task.lm_damping * float(ri.dot(ri)) / (task.gain * task.gain)
        return None if extra == 0.0 else self.solver.options.damping + extra

    def solve(self, state: State, dt: float) -> HierarchicalIKResult:
        """One hierarchical step from ``state`` during ``dt`` [s]."""
        if not isinstance(state, State):
            raise InvalidInputError(
                f"state must be a taskspace State (robot.state(q)), got {type(state).__name__}"
            )
        dt = check_positive(dt, "dt")
        with self._lock:
            return self._solve(state, dt)

    def _solve_native(self, state: State, dt: float) -> HierarchicalIKResult | str:
        """The compiled closed-form step, or why it declined (the caller holds the lock)."""
        native = self._native
        assert native is not None
        t0 = time.perf_counter()
        result = native.solve(state, dt, self.solver.options.damping)
        if isinstance(result, int) and result < 0:  # no kernel call (LM damping)
            return DECLINED[result]
        if not native.squared_rhs <= _MAX_SQUARED_RESIDUAL:  # also NaN: the Python path
            return "a weighted task residual is too large"  # raises, naming the level
        if isinstance(result, int):
            return DECLINED[result]
        x = result.x
        solve_time = result.solve_time
        return HierarchicalIKResult(
            True,
            x,
            x / dt,
            result.residuals,
            result.violations,
            result,
            time.perf_counter() - t0 - solve_time,
            solve_time,
            native=True,
        )

    def _solve(self, state: State, dt: float) -> HierarchicalIKResult:
        declined = ""
        if self._native_backoff:
            # the last steps' level QPs had an active row: the kernel would decline again
            # (its call is wasted); the Python cascade answers until it finds them inactive
            declined = DECLINED[-2]
        elif self._native is not None or (not self._native_checked and self.native):
            answer = self._solve_native(state, dt)
            if not isinstance(answer, str):
                return answer
            declined = answer
            if answer in _BACKOFF:
                self._native_backoff = _BACKOFF_STEPS
        t0 = time.perf_counter()
        levels = self._build(state, dt)
        r_all = self._r_all
        if not float(r_all.dot(r_all)) <= _MAX_SQUARED_RESIDUAL:  # also NaN and overflow
            self._residual_error(levels)
        nv = self.robot.nv
        lb, ub, _ = self._boxes.fill(state, dt)
        C = l = u = None
        blocks: list[RowBlock] = []
        if self._hard_inequalities:
            (C, l, u), blocks = self._hard_inequalities.fill(state, dt)
            if not blocks:
                C = l = u = None
        t1 = time.perf_counter()
        result = self.solver.solve(
            levels,
            nv,
            lb=lb,
            ub=ub,
            C=C,
            l=l,
            u=u,
            hard_names=blocks,
        )
        t2 = time.perf_counter()
        if self._native_backoff:
            self._native_backoff -= 1
            if result.status is QPStatus.UNCONSTRAINED:
                self._native_backoff = 0  # every inequality and bound inactive again
        if not np.isfinite(result.x).all():
            raise SolverError(
                "the hierarchical step is not finite (overflow): the weighted task residuals "
                "are too large; check the targets and weights (|weight * error| must stay far "
                "below 1e150)"
            )
        return HierarchicalIKResult(
            result.success,
            result.x,
            result.x / dt,
            result.residuals,
            result.violations,
            result,
            t1 - t0,
            t2 - t1,
            native_declined=declined,
            culprits=list(result.culprits),
        )

    def _residual_error(self, levels: list[HierarchyLevel]) -> None:
        """Raise the error naming the level whose weighted residual is too large."""
        for level in levels:
            with np.errstate(over="ignore", invalid="ignore"):
                norm = float(np.linalg.norm(level.r))
            if not norm <= MAX_WEIGHTED_RESIDUAL:
                raise SolverError(
                    f"{level.name}: the weighted task residual |sqrt(weight) * gain * error| = "
                    f"{norm:.3g} is not finite or above {MAX_WEIGHTED_RESIDUAL:g}; check the "
                    "targets and weights"
                )
        raise SolverError(
            f"the weighted task residuals of the levels together exceed {MAX_WEIGHTED_RESIDUAL:g}"
            "; check the targets and weights"
        )

    def advance(self, state: State, dt: float) -> HierarchicalIKResult:
        """One step that moves ``state``: solve at it, then ``state`` goes to ``q (+) dq``.

        The loop ``state.update(q); result = solve(state, dt); q = q (+) result.dq`` in one
        call (as :meth:`DifferentialIK.advance <taskspace.ik.DifferentialIK.advance>`):
        ``state`` ends exactly as ``state.update(q (+) dq, v)`` would leave it, with ``v =
        dq / dt`` when the state has a velocity and none otherwise. The state moves by the
        returned step whatever its status (as :meth:`step`); check ``result.success``. The
        state's previous ``q`` is not modified.

        Args:
            state: current state, moved to the new configuration.
            dt: time step [s].
        """
        result = self.solve(state, dt)  # validates the state
        dt = check_positive(dt, "dt")
        dq = result.dq
        state.update(
            pin.integrate(self.robot._model, state._q, dq),
            dq / dt if state._has_velocity else None,
            validate=False,
        )
        return result

    def step(self, state: State, dt: float) -> tuple[FloatArray, HierarchicalIKResult]:
        """Solve one step and return ``(q (+) dq, result)``."""
        result = self.solve(state, dt)
        return np.asarray(pin.integrate(self.robot._model, state.q, result.dq)), result


__all__ = ["HierarchicalIK", "HierarchicalIKResult"]
