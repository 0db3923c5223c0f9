"""The compiled step of :class:`~taskspace.ik.HierarchicalIK` (closed form or level QPs).

The kernel is ``taskspace/_native/hier_kernel.hpp`` (part of ``_ik_kernel``).

One kernel call fills every level's weighted task rows (the rows of
:meth:`~taskspace.qp.rows.TaskRowStack.velocity`, evaluated from the declared
:class:`~taskspace.features.compiled.CompiledTerm` of each task's feature, as the compiled
weighted IK does), combines the boxes, runs the equality cascade of
:class:`~taskspace.qp.hierarchy.HierarchySolver` (one QR per level, the same rank test) and
checks the bounds and the inequality rows at its point. The inequality rows themselves (a
level's constraints, the hard ones) are evaluated here in Python and passed to the kernel.

When every row holds at the cascade's point, that point is the cascade of QPs' solution (each
level's QP has no active inequality: its closed form is its optimum); the kernel returns it
with each level's KKT residuals. When an inequality or a bound is violated there, the kernel
solves the Python cascade's level QPs itself (the same QPs: each level in the nullspace of the
levels above, its own rows with slacks, the rows of the levels above held) by a dual
active-set method (Goldfarb-Idnani, refined on its final active set) and returns them when
each level's KKT residuals meet 1e-9 (absolute and relative). Otherwise (a level close to
rank-deficient, a level QP not certified, a held row vanishing while violated, a failed
factorization) the kernel declines and the Python cascade answers the step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from taskspace._native import ik_kernel
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError
from taskspace.features.compiled import (
    IK_KINDS,
    CompiledConstraint,
    CompiledTerm,
    compiled_constraint,
    compiled_term,
)
from taskspace.ik._native_stack import _FULL_TANGENT, _REGISTER, split_boxes, write_scaling
from taskspace.model.robot import Robot
from taskspace.model.state import State
from taskspace.qp.hierarchy import HierarchyResult
from taskspace.qp.kkt import KKTResiduals
from taskspace.qp.result import QPResult, QPStatus
from taskspace.qp.rows import InequalityStack
from taskspace.tasks import Task

DECLINED = {
    -1: "a task has Levenberg-Marquardt damping (the kernel's damping is fixed)",
    1: "a level is close to rank-deficient (pivoted QR / damped SVD)",
    2: "a factorization failed or the step is not finite",
    3: "an inequality or a bound is violated at the closed-form point (level QPs)",
    4: "a level QP was not solved to its KKT tolerance (1e-9) by the compiled active-set method",
    5: "a held or bound row vanishes in a level's freedom while its bounds exclude the point "
    "(the Python cascade reports it as a culprit)",
    -2: "not tried: an earlier step's kernel call declined for an active inequality or bound "
    "(tried again once the Python cascade finds every inequality and bound inactive, or "
    "after 25 steps)",
}
"""Why the kernel declined a step (its status), recorded on the Python path's result."""


def supported(levels: Sequence[Sequence[Task]]) -> bool:
    """Whether the compiled closed-form step can evaluate these levels' tasks."""
    module = ik_kernel()
    if module is None or not hasattr(module, "HierarchicalIKKernel"):
        return False
    return all(
        type(t).rows is Task.rows
        and (term := compiled_term(t.feature)) is not None
        and term.kind in IK_KINDS
        for tasks in levels
        for t in tasks
    )


_BOUND_KINDS = {"com": 2, "position": 1}  # the kernel's term kinds


def _compiled_bounds(c: Constraint) -> CompiledConstraint | None:
    """The bounds ``c`` declares on a term the kernel evaluates, or ``None``.

    Read from its class's own ``compiled_constraint``; ``None``: its rows are evaluated in
    Python.
    """
    rows = compiled_constraint(c)
    if rows is None or rows.kind != "bounds" or rows.term is None:
        return None
    return rows if rows.term.kind in _BOUND_KINDS else None


class _NativeLevelResult(QPResult):
    """A level answered by the compiled step.

    In closed form: ``x`` is the level's step ``z``, ``kkt`` the residuals of
    :func:`~taskspace.qp.kkt.least_squares_kkt_residuals`. By a level QP (an active
    inequality or bound; status ``SOLVED``): ``x`` is the QP's ``(z, w)`` (step and slacks of
    the level's own inequality rows, as the Python cascade's level QP), ``kkt`` the QP's
    residuals (:func:`~taskspace.qp.kkt.kkt_residuals`). Computed by the kernel; the
    :class:`KKTResiduals` is made on first access.
    """

    def __init__(self, z: np.ndarray, info: np.ndarray) -> None:
        self._info: np.ndarray | None = None
        if info[12]:
            super().__init__(
                True, QPStatus.SOLVED, z, float(info[10]), int(info[13]), 0.0, _QP_BACKEND
            )
        else:
            super().__init__(True, QPStatus.UNCONSTRAINED, z, float(info[10]), 0, 0.0, _BACKEND)
        self._info = info

    @property  # type: ignore[override]
    def kkt(self) -> KKTResiduals:
        """The level's KKT residuals (see the class)."""
        info = self._info
        if info is not None:
            self._info = None
            self._kkt = KKTResiduals(*info[3:10].tolist())
        return self._kkt

    @kkt.setter
    def kkt(self, value: KKTResiduals) -> None:
        self._kkt = value


_BACKEND = "native closed form"
_QP_BACKEND = "native active set"


class _NativeHierarchyResult(HierarchyResult):
    """The cascade's result from the kernel.

    The per-level results are made on first access of :attr:`level_results` (from the
    kernel's per-level data and steps, kept here).
    """

    def __init__(
        self, x: np.ndarray, info: np.ndarray, steps: np.ndarray, solve_time: float, qp: bool
    ) -> None:
        # the fields of HierarchyResult, set directly (the level results come later)
        self.success = True
        self.status = QPStatus.SOLVED if qp else QPStatus.UNCONSTRAINED
        self.x = x
        self.residuals = info[:, 0].tolist()
        self.violations = info[:, 1].tolist()
        self.nullspace_dims = info[:, 2].astype(int).tolist()
        self.solve_time = solve_time
        self.culprits = []
        self._pending: tuple[np.ndarray, np.ndarray] | None = (info, steps)
        self._level_results: list[QPResult] = []

    @property  # type: ignore[override]
    def level_results(self) -> list[QPResult]:
        """Per level, its result (closed form or level QP, see ``_NativeLevelResult``).

        ``x``: the level's step, ``kkt``: its KKT residuals computed by the kernel.
        """
        pending = self._pending
        if pending is not None:
            self._pending = None
            info, steps = pending
            pos = 0
            for row in info:
                size = int(row[11])
                self._level_results.append(_NativeLevelResult(steps[pos : pos + size], row))
                pos += size
        return self._level_results

    @level_results.setter
    def level_results(self, value: list[QPResult]) -> None:
        self._pending = None
        self._level_results = value


class NativeHierarchy:
    """Owns one compiled hierarchical kernel for fixed levels of tasks and box constraints.

    The kernel is built for ``robot.model`` and only receives the ``pin.Data`` of a
    :class:`~taskspace.model.State` of that model. Not thread-safe (the kernel holds its
    buffers): :class:`~taskspace.ik.HierarchicalIK` serializes its calls with its lock.
    """

    def __init__(
        self,
        robot: Robot,
        levels: Sequence[Sequence[Task | Constraint]],
        constraints: Sequence[Constraint],
    ) -> None:
        module = ik_kernel()
        assert module is not None
        model = robot._model
        self.robot = robot
        self.model = model
        self.nv = robot.nv
        kernel = module.HierarchicalIKKernel(robot.nv, robot.nq)
        rows: list[tuple[Task, CompiledTerm]] = []
        full: list[tuple[Task, CompiledTerm]] = []
        level_tasks = [[t for t in level if isinstance(t, Task)] for level in levels]
        for tasks in level_tasks:
            for t in tasks:
                term = compiled_term(t.feature)
                if term is None or term.kind not in IK_KINDS:
                    raise InvalidInputError(
                        f"task '{t.name}': its feature declares no compiled term"
                    )
                _REGISTER[term.kind](kernel, model, term)
                (full if term.kind in _FULL_TANGENT else rows).append((t, term))
        # bounds declared on a CoM or frame origin: evaluated by the kernel (rows after the
        # tasks'); the other inequality rows are evaluated here and passed to each solve
        self._bounds: list[Constraint] = []
        self._bound_keys: list[tuple[bytes, bytes, float]] = []
        level_constraints = [[c for c in level if isinstance(c, Constraint)] for level in levels]
        for k, group in enumerate([*level_constraints, list(constraints)]):
            level = k if k < len(levels) else -1
            for c in group:
                declared = _compiled_bounds(c)
                if declared is None:
                    continue
                assert declared.term is not None  # (_compiled_bounds checked it)
                kernel.add_bounds(
                    model,
                    _BOUND_KINDS[declared.term.kind],
                    -1 if declared.term.frame_id is None else declared.term.frame_id,
                    declared.lower,
                    declared.upper,
                    declared.gain,
                    level,
                )
                self._bounds.append(c)
                self._bound_keys.append(self._bound_key(declared))
        self._level_inequalities = [
            InequalityStack([c for c in group if _compiled_bounds(c) is None], robot.nv)
            for group in level_constraints
        ]
        self._hard_inequalities = InequalityStack(
            [c for c in constraints if _compiled_bounds(c) is None], robot.nv
        )
        kernel.set_levels([len(tasks) for tasks in level_tasks])
        # the kernel's target order: the row tasks, then the full-tangent (posture) ones
        terms = rows + full
        self.tasks = [t for t, _ in terms]
        self._terms = [term for _, term in terms]
        self._n_rows = sum(t.dim for t, _ in rows) + 3 * len(self._bounds)
        self._n_full = len(full)
        self._keys: list[tuple[Any, Any]] = []
        self.kernel = kernel
        self._position, self._position_limits, self._hard, self._soft = split_boxes(
            robot,
            constraints,
            "compiled hierarchical IK position limits",
            self._send_position_limits,
        )
        self._out = np.zeros(robot.nv)
        self._steps = np.zeros(len(levels) * robot.nv)
        self._n_levels = len(levels)
        self._zeros = [np.zeros(3) for _ in self._bounds]  # the bounds' targets
        self.squared_rhs = 0.0  # of the last solve: the sum of the squared weighted residuals
        self.build_time = 0.0

    @staticmethod
    def _bound_key(declared: CompiledConstraint) -> tuple[bytes, bytes, float]:
        lower = np.asarray(declared.lower, dtype=float)
        upper = np.asarray(declared.upper, dtype=float)
        return (lower.tobytes(), upper.tobytes(), declared.gain)

    def _send_position_limits(self, position: Any) -> None:
        self.kernel.set_position_limits(*position.kernel_arguments())

    def _scale(self) -> None:
        """Send the rows' weights and gains to the kernel (the weighted kernel's layout)."""
        nv = self.nv
        w = np.zeros(self._n_rows + nv * self._n_full)
        c = np.zeros_like(w)
        k = 0
        bounds_at: int | None = None
        for t, term in zip(self.tasks, self._terms):
            if term.kind in _FULL_TANGENT and bounds_at is None:
                bounds_at = k  # the bounds' rows: after the row tasks', weight 1, scale 1
                k += 3 * len(self._bounds)
            k = write_scaling(w, c, k, t, term, nv)
        if bounds_at is None:
            bounds_at = k
        w[bounds_at : bounds_at + 3 * len(self._bounds)] = 1.0
        c[bounds_at : bounds_at + 3 * len(self._bounds)] = 1.0
        self.kernel.set_scaling(w, c)
        self._keys = [(t.sqrt_weight, t.gain) for t in self.tasks]

    def solve(self, state: State, dt: float, damping: float) -> HierarchyResult | int:
        """The step's cascade result, or why the kernel declined (a key of :data:`DECLINED`).

        -1: a task has Levenberg-Marquardt damping, which the kernel's fixed damping does not
        model; > 0: the kernel's status.

        Raises the Python path's errors for a state of another robot or a task without a
        target; the caller checks :attr:`squared_rhs` (the weighted residuals' size).
        """
        model = self.model
        if state._model is not model:
            raise InvalidInputError(
                f"this IK solver is built for robot '{self.robot.name}'; the state belongs to "
                f"robot '{state.robot.name}': make the state with this robot's state(q)"
            )
        keys = self._keys
        rescale = not keys
        targets: list[Any] = []
        n_rows = len(self.tasks) - self._n_full
        for i, t in enumerate(self.tasks):
            if t.lm_damping:
                return -1
            if not rescale and (t.sqrt_weight is not keys[i][0] or t.gain is not keys[i][1]):
                rescale = True
            if i == n_rows:
                targets += self._zeros
            targets.append(t._target)
        if n_rows == len(self.tasks):
            targets += self._zeros
        if rescale:
            self._scale()
        for i, c in enumerate(self._bounds):
            declared = _compiled_bounds(c)
            if declared is None:
                raise InvalidInputError(
                    f"constraint '{c.name}' no longer declares compiled bounds on a CoM or "
                    "frame origin (make a new HierarchicalIK)"
                )
            key = self._bound_key(declared)
            if key != self._bound_keys[i]:  # bounds reassigned or changed in place
                self.kernel.set_bounds(i, declared.lower, declared.upper, declared.gain)
                self._bound_keys[i] = key
        if self._position_limits is not None:
            self._position_limits.sync()
        inequalities: list[Any] = []
        for stack in self._level_inequalities:
            rows = None
            if stack:
                rows, blocks = stack.fill(state, dt)
                if not blocks:
                    rows = None
            inequalities.append(rows)
        hard = None
        if self._hard_inequalities:
            hard, blocks = self._hard_inequalities.fill(state, dt)
            if not blocks:
                hard = None
        hard_boxes, soft_boxes = self._hard, self._soft
        out, steps = self._out, self._steps
        try:
            status, self.squared_rhs, self.build_time, solve_time, qp = self.kernel.solve(
                model,
                state._data,
                state.q,
                targets,
                [b for c in hard_boxes if (b := c.bounds(state, dt)) is not None]
                if hard_boxes
                else [],
                [b for c in soft_boxes if (b := c.bounds(state, dt)) is not None]
                if soft_boxes
                else [],
                inequalities,
                hard,
                damping,
                out,
                steps,
            )
        except (TypeError, ValueError, RuntimeError):
            for t in self.tasks:
                t._require_target()  # a task without a target: raises, naming it
            raise
        if status != 0:
            return int(status)
        # (levels, 14); eigenpy gives a one-row matrix (one level) as a vector
        info = self.kernel.info().reshape(self._n_levels, -1)
        steps = np.asarray(self.kernel.qp_steps()).reshape(-1) if qp else steps.copy()
        return _NativeHierarchyResult(out.copy(), info, steps, solve_time, qp)

    def level_rows(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Level ``k``'s rows ``(J, r)`` of the last solve (copies; for tests)."""
        J, r = self.kernel.level_rows(k)
        return np.asarray(J), np.asarray(r).reshape(-1)
