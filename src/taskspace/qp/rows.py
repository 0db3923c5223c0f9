"""The stacking layer: task rows, boxes and constraint rows written into a QP's arrays.

Tasks, constraints and contacts return typed rows (:mod:`taskspace.features.rows`); this
module holds the one set of rules that stacks them, used by every consumer:

* :class:`TaskRowStack`: the weighted least-squares rows of several tasks in preallocated
  buffers, at velocity level (``sqrt(rho) J dq ~ -sqrt(rho) gain e``, each task's
  :meth:`~taskspace.tasks.Task.rows`), acceleration level (``sqrt(rho) J a ~ sqrt(rho)
  (y''* - Jdot v)`` with ``y''* = y''_ref - kp e - kd (J v - y'_ref)``, the PD law applied
  once to the whole stack) or as Gauss-Newton rows of the weighted residuals
  (``sqrt(rho) J``, ``sqrt(rho) e``). Used by :class:`~taskspace.ik.DifferentialIK`,
  :class:`~taskspace.ik.HierarchicalIK`, the inverse-dynamics QP, operational-space
  control and path optimization (the task rows of each time slice).
* :func:`combine_boxes`: the intersection of boxes with the rule for conflicts (physical
  boxes win over position boxes); :func:`combine_bounds` applies it to constraints.
* :class:`InequalityStack`: the inequality rows of constraints in preallocated buffers.
* :class:`WeightedQPBuilder`: the weighted velocity-level QP of the IK step,
  ``min |M x - r|^2 + mu |x|^2`` with equality task rows, inequality rows and a box, written
  into preallocated arrays.

The compiled IK kernel (``taskspace/_native``) evaluates the same rules for the stacks it
serves (see :mod:`taskspace.ik._native_stack`).

Thread safety: :class:`TaskRowStack`, :class:`InequalityStack` and :class:`WeightedQPBuilder` are
workspaces (preallocated buffers refilled in place by every call; the returned arrays are views of
them) and are not locked: one per thread, as owned by the solvers that build them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray
from taskspace.constraints.constraint import Constraint
from taskspace.errors import ShapeError
from taskspace.features.rows import INF, Box, InequalityRows, TaskRows
from taskspace.qp.problem import QPProblem, RowBlock
from taskspace.tasks import Task

if TYPE_CHECKING:
    from taskspace.model.state import State


# ---------------------------------------------------------------------- task rows
class TaskRowStack:
    """The rows of several tasks stacked in preallocated buffers, refilled in place.

    ``J`` (m, nv) and ``rhs`` (m,) hold the weighted rows of every task, in order; each
    task's rows are the slice :attr:`slices` ``[i]``. The buffers may be given (views into a
    larger array, e.g. every level of a hierarchy in one vector).

    Args:
        tasks: the tasks (each with a target when the stack is filled).
        nv: tangent dimension of the robot.
        J, rhs: optional output buffers of shapes (m, nv) and (m,).
    """

    def __init__(
        self,
        tasks: Sequence[Task],
        nv: int,
        J: FloatArray | None = None,
        rhs: FloatArray | None = None,
    ) -> None:
        self.tasks = list(tasks)
        m = sum(t.dim for t in self.tasks)
        self.J = np.zeros((m, nv)) if J is None else J
        self.rhs = np.zeros(m) if rhs is None else rhs
        if self.J.shape != (m, nv):
            raise ShapeError("task row buffer J", (m, nv), self.J.shape)
        if self.rhs.shape != (m,):
            raise ShapeError("task row buffer rhs", (m,), self.rhs.shape)
        self.slices: list[slice] = []
        row = 0
        for t in self.tasks:
            self.slices.append(slice(row, row + t.dim))
            row += t.dim
        self._pairs = list(zip(self.tasks, self.slices))
        # velocity level: each task's rows written straight into views of the buffers (no
        # per-task temporaries); a Task subclass that overrides ``rows`` is asked for them
        self._velocity_views = [
            (task, self.J[rows], self.rhs[rows], type(task).rows is Task.rows)
            for task, rows in self._pairs
        ]
        # acceleration level: raw rows and per-row gains and weights
        self._J_raw: FloatArray | None = None
        self._e = np.zeros(m)
        self._tmp = np.zeros(m)
        self._drift = np.zeros(m)
        self._w = np.ones(m)
        self._neg_w = -self._w
        self._w_column = self._w[:, None]  # a view: follows _w
        self._kp = np.zeros(m)
        self._kd = np.zeros(m)
        self._keys: list[tuple[Any, ...]] = [()] * len(self.tasks)

    @property
    def size(self) -> int:
        """Number of rows."""
        return int(self.rhs.shape[0])

    def velocity(self, state: State) -> TaskRows:
        """Rows ``sqrt(rho) J dq ~ -sqrt(rho) gain e`` (each task's :meth:`Task.rows`)."""
        for task, J_rows, rhs_rows, plain in self._velocity_views:
            if not plain:
                J_rows[...], rhs_rows[...] = task.rows(state)
                continue
            # Task.rows, written in place: the same products, bit for bit
            target = task._target
            if target is None:
                task._require_target()  # raises, naming the task
            e, Ji = task.feature.residual_and_jacobian(state, target)
            w = task.sqrt_weight
            if isinstance(w, float):
                if w == 1.0:
                    J_rows[...] = Ji
                else:
                    np.multiply(w, Ji, out=J_rows)
            else:
                np.multiply(w[:, None], Ji, out=J_rows)
            np.multiply(-task.gain * w, e, out=rhs_rows)
        return TaskRows(self.J, self.rhs)

    def residual(self, state: State) -> TaskRows:
        """Gauss-Newton rows ``(sqrt(rho) J, sqrt(rho) e)`` of ``sum_i rho_i |phi_i (-) y_i*|^2``.

        The cost near ``q`` is ``|J dx + e|^2`` in these rows; the velocity rows of
        :meth:`velocity` are the same with ``rhs = -gain sqrt(rho) e``.
        """
        self._refresh()
        if self._J_raw is None:
            self._J_raw = np.zeros_like(self.J)
        J_raw, e_all = self._J_raw, self._e
        for task, rows in self._pairs:
            e_all[rows], J_raw[rows] = task.feature.residual_and_jacobian(
                state, task._require_target()
            )
        np.multiply(J_raw, self._w_column, out=self.J)
        np.multiply(e_all, self._w, out=self.rhs)
        return TaskRows(self.J, self.rhs)

    def _refresh(self) -> None:
        """Re-read the weights and gains of the tasks whose values were reassigned."""
        keys = self._keys
        for i, task in enumerate(self.tasks):
            k = keys[i]
            if (
                k
                and task.sqrt_weight is k[0]
                and task.gain is k[1]
                and task.kp is k[2]
                and task.kd is k[3]
            ):
                continue
            rows = self.slices[i]
            self._w[rows] = task.sqrt_weight
            self._kp[rows] = task.kp
            self._kd[rows] = task.kd
            np.negative(self._w, out=self._neg_w)
            keys[i] = (task.sqrt_weight, task.gain, task.kp, task.kd)

    def acceleration(self, state: State) -> TaskRows:
        """Rows ``sqrt(rho) J a ~ sqrt(rho) (y''* - Jdot v)`` at ``state`` (with velocity).

        ``y''* = y''_ref - kp e - kd (J v - y'_ref)`` (slides 5:28, 5:34), applied once to
        the whole stack; equal to each task's :meth:`Task.acceleration_rows`.
        """
        self._refresh()
        if self._J_raw is None:
            self._J_raw = np.zeros_like(self.J)
        J_raw, e_all, drift = self._J_raw, self._e, self._drift
        offset: FloatArray | None = None
        for task, rows in self._pairs:
            # the feature's values directly (Task.feature_rows without the tuple: hot loop)
            feature = task.feature
            target = task._target
            if target is None:
                task._require_target()  # raises, naming the task
            e_all[rows], J_raw[rows] = feature.residual_and_jacobian(state, target)
            drift[rows] = feature.drift(state)
            if task.reference_velocity is not None or task.reference_acceleration is not None:
                if offset is None:
                    offset = np.zeros_like(drift)
                if task.reference_velocity is not None:
                    offset[rows] += task.kd * task.reference_velocity
                if task.reference_acceleration is not None:
                    offset[rows] += task.reference_acceleration
        # rhs = -w (kd J v + kp e + Jdot v - kd y'_ref - y''_ref)
        rhs = self.rhs
        np.multiply(J_raw.dot(state.v), self._kd, out=rhs)
        rhs += np.multiply(self._kp, e_all, out=self._tmp)
        rhs += drift
        if offset is not None:
            rhs -= offset
        rhs *= self._neg_w
        np.multiply(J_raw, self._w_column, out=self.J)
        return TaskRows(self.J, rhs)


# ---------------------------------------------------------------------- boxes
def _intersect(
    boxes: Sequence[tuple[FloatArray, FloatArray]], nv: int
) -> tuple[FloatArray, FloatArray]:
    if not boxes:
        return np.full(nv, -INF), np.full(nv, INF)
    lb, ub = boxes[0]
    if len(boxes) == 2:  # the common case (position and velocity limits): no loop
        blb, bub = boxes[1]
        return np.maximum(lb, blb), np.minimum(ub, bub)
    for k in range(1, len(boxes)):
        blb, bub = boxes[k]
        lb = np.maximum(lb, blb)
        ub = np.minimum(ub, bub)
    return lb, ub


def combine_boxes(
    hard: Sequence[tuple[FloatArray, FloatArray]],
    soft: Sequence[tuple[FloatArray, FloatArray]],
    nv: int,
) -> tuple[FloatArray, FloatArray]:
    """Intersect boxes; physical (``hard``) boxes win where the boxes conflict.

    Hard boxes (velocity, acceleration limits) intersect; where they conflict the bound is
    the midpoint of the gap. Soft boxes (position limits) intersect likewise (an empty soft
    box alone: its midpoint). Where both exist, the soft box is cut by the hard one; a soft
    box entirely above (below) the hard one gives the hard upper (lower) bound (a
    configuration outside its limits moves back as fast as allowed), an empty soft box its
    midpoint clipped to the hard box. The returned arrays may be those of a single input
    box: do not modify them.

    Args:
        hard, soft: boxes (:class:`~taskspace.features.rows.Box` or ``(lower, upper)``
            pairs) of size ``nv``.
        nv: number of variables.

    Returns:
        ``(lower, upper)``.
    """
    hard_lb, hard_ub = _intersect(hard, nv)
    bad = hard_lb > hard_ub
    if bad.any():  # conflicting hard boxes (acceleration vs velocity): midpoint of the gap
        hard_lb = hard_lb.copy()
        hard_ub = hard_ub.copy()
        hard_lb[bad] = hard_ub[bad] = 0.5 * (hard_lb[bad] + hard_ub[bad])
    if not soft:
        return hard_lb, hard_ub
    soft_lb, soft_ub = _intersect(soft, nv)
    if not hard:
        bad = soft_lb > soft_ub
        if bad.any():  # empty soft box (margins): center it
            soft_lb = soft_lb.copy()
            soft_ub = soft_ub.copy()
            soft_lb[bad] = soft_ub[bad] = 0.5 * (soft_lb[bad] + soft_ub[bad])
        return soft_lb, soft_ub
    lb = np.maximum(hard_lb, soft_lb)
    ub = np.minimum(hard_ub, soft_ub)
    bad = lb > ub
    if bad.any():
        # soft box entirely above (or below) the hard one: go to the nearest hard bound; an
        # empty soft box (which may reach past both sides of the hard box) is centred below
        soft_empty = soft_lb > soft_ub
        above = (soft_lb > hard_ub) & ~soft_empty
        below = (soft_ub < hard_lb) & ~soft_empty
        lb = np.where(bad & above, hard_ub, lb)
        ub = np.where(bad & above, hard_ub, ub)
        lb = np.where(bad & below, hard_lb, lb)
        ub = np.where(bad & below, hard_lb, ub)
        soft_conflict = bad & ~above & ~below  # soft box itself empty (margins): center it
        if soft_conflict.any():
            mid = 0.5 * (soft_lb + soft_ub)
            lb = np.where(soft_conflict, np.clip(mid, hard_lb, hard_ub), lb)
            ub = np.where(soft_conflict, lb, ub)
    return lb, ub


def combine_bounds(
    constraints: Sequence[Constraint], state: State, dt: float, nv: int
) -> tuple[FloatArray, FloatArray, list[RowBlock]]:
    """The box of ``constraints`` on the step (:func:`combine_boxes`) and its block names."""
    hard: list[Box] = []
    soft: list[Box] = []
    names: list[RowBlock] = []
    for c in constraints:
        box = c.bounds(state, dt)
        if box is not None:
            names.append(RowBlock(c.name, 0, nv))
            (hard if c.hard_bounds else soft).append(box)
    lb, ub = combine_boxes(hard, soft, nv)
    return lb, ub, names


class BoxStack:
    """The box of several constraints (:func:`combine_bounds`) in preallocated buffers.

    The constraints that declare no box (those not overriding ``bounds``) are left out once;
    the common case of one physical and one position box (velocity and position limits) is
    intersected into the buffers, and any conflict, NaN or other mix takes
    :func:`combine_boxes` (same values as :func:`combine_bounds`, bit for bit). The returned
    arrays may be the buffers, refilled by the next call, or a single input box: do not
    modify them.

    Args:
        constraints: the constraints.
        nv: number of variables.
    """

    def __init__(self, constraints: Sequence[Constraint], nv: int) -> None:
        self.constraints = [c for c in constraints if type(c).bounds is not Constraint.bounds]
        self.nv = nv
        self._lb = np.zeros(nv)
        self._ub = np.zeros(nv)
        self._blocks = [RowBlock(c.name, 0, nv) for c in self.constraints]

    def fill(self, state: State, dt: float) -> tuple[FloatArray, FloatArray, list[RowBlock]]:
        """``(lower, upper, blocks)`` at ``state`` for a step of ``dt`` [s]."""
        nv = self.nv
        hard: list[Box] = []
        soft: list[Box] = []
        blocks = self._blocks
        for i, c in enumerate(self.constraints):
            box = c.bounds(state, dt)
            if box is None:  # this step without a box: name only those with one
                if blocks is self._blocks:
                    blocks = blocks[:i]
                continue
            (hard if c.hard_bounds else soft).append(box)
            if blocks is not self._blocks:
                blocks.append(self._blocks[i])
        if len(hard) == 1 and len(soft) == 1:
            try:
                lb = np.maximum(hard[0][0], soft[0][0], out=self._lb)
                ub = np.minimum(hard[0][1], soft[0][1], out=self._ub)
            except ValueError:  # boxes not of size nv: as combine_boxes treats them
                return (*combine_boxes(hard, soft, nv), blocks)
            # no conflict anywhere (a conflict of the hard box alone is one here too)
            if np.less_equal(lb, ub).all():
                return lb, ub, blocks
        lb, ub = combine_boxes(hard, soft, nv)
        return lb, ub, blocks


# ---------------------------------------------------------------------- inequality rows
class InequalityStack:
    """The rows ``l <= C x <= u`` of several constraints in preallocated buffers.

    The number of rows may change between calls (collision dampers add a row per pair
    within their influence distance); the buffers grow when needed and the returned arrays
    are views of their first rows, refilled by the next call.

    Args:
        constraints: the constraints (those without inequality rows are skipped).
        n: number of variables (columns of ``C``).
    """

    def __init__(self, constraints: Sequence[Constraint], n: int) -> None:
        self.constraints = [
            c for c in constraints if type(c).inequalities is not Constraint.inequalities
        ]
        self.n = n
        self._C = np.zeros((0, n))
        self._l = np.zeros(0)
        self._u = np.zeros(0)

    def __bool__(self) -> bool:
        return bool(self.constraints)

    def _reserve(self, m: int) -> None:
        if m > self._C.shape[0]:
            m = max(m, 2 * self._C.shape[0])
            self._C = np.zeros((m, self.n))
            self._l = np.zeros(m)
            self._u = np.zeros(m)

    def fill(self, state: State, dt: float) -> tuple[InequalityRows, list[RowBlock]]:
        """Stacked rows at ``state`` for a step of ``dt`` [s] and the block of each constraint."""
        parts: list[tuple[str, Any]] = []
        m = 0
        for c in self.constraints:
            rows = c.inequalities(state, dt)
            if rows is None or rows[0].shape[0] == 0:
                continue
            parts.append((c.name, rows))
            m += rows[0].shape[0]
        self._reserve(m)
        C, l, u = self._C[:m], self._l[:m], self._u[:m]
        blocks: list[RowBlock] = []
        k = 0
        for name, (Ci, li, ui) in parts:
            d = Ci.shape[0]
            C[k : k + d] = Ci
            l[k : k + d] = li
            u[k : k + d] = ui
            blocks.append(RowBlock(name, k, k + d))
            k += d
        return InequalityRows(C, l, u), blocks


def stack_inequalities(
    constraints: Sequence[Constraint], state: State, dt: float
) -> tuple[FloatArray, FloatArray, FloatArray, list[RowBlock]] | None:
    """Stack the rows ``l <= C dq <= u`` of ``constraints`` (``None`` when there are none)."""
    if not constraints:
        return None
    stack = InequalityStack(constraints, state.robot.nv)
    (C, l, u), blocks = stack.fill(state, dt)
    return (C, l, u, blocks) if blocks else None


# ---------------------------------------------------------------------- the weighted QP
class WeightedQPBuilder:
    """The QP of one weighted velocity-level step, written into preallocated arrays.

    ``min_x |M x - r|^2 + mu |x|^2``, as ``1/2 x^T H x + g^T x`` with ``H = M^T M + mu I``
    and ``g = -M^T r`` (half the objective: the same minimizer), where ``mu`` is the damping
    plus, per task with Levenberg-Marquardt damping, ``lm_damping |sqrt(rho) e|^2`` (its rows
    of ``r`` divided by its gain), subject to ``A x = b``
    (equality tasks),
    ``l <= C x <= u`` (constraint rows) and ``lb <= x <= ub`` (the constraints' boxes
    combined by :func:`combine_boxes`).

    Args:
        tasks: weighted tasks (rows ``M``, ``r``).
        constraints: boxes and inequality rows.
        equality_tasks: tasks imposed exactly (rows ``A``, ``b``).
        nv: number of variables.
        damping: ``mu`` [1/rad^2].
    """

    def __init__(
        self,
        tasks: Sequence[Task],
        constraints: Sequence[Constraint],
        equality_tasks: Sequence[Task],
        nv: int,
        damping: float,
    ) -> None:
        self.nv = nv
        self.damping = float(damping)
        self.constraints = list(constraints)
        self.objective = TaskRowStack(tasks, nv)
        self.equalities = TaskRowStack(equality_tasks, nv)
        self._eq_blocks: list[RowBlock] = []
        k = 0
        for t in self.equalities.tasks:
            self._eq_blocks.append(RowBlock(f"task '{t.name}'", k, k + t.dim))
            k += t.dim
        self.inequalities = InequalityStack(constraints, nv)
        self.boxes = BoxStack(constraints, nv)
        self._H = np.zeros((nv, nv))
        self._g = np.zeros(nv)
        self._diagonal = self._H.reshape(-1)[:: nv + 1]  # a view: the diagonal of H
        self._empty_rows = np.zeros((0, nv))
        self._empty = np.zeros(0)

    def build(self, state: State, dt: float) -> QPProblem:
        """The QP at ``state`` for a step of ``dt`` [s] (arrays refilled by the next call)."""
        M, r = self.objective.velocity(state)
        H, g = self._H, self._g
        np.dot(M.T, M, out=H)
        mu = self.damping
        for task, rows in self.objective._pairs:
            if task.lm_damping:
                ri = r[rows]
                mu += task.lm_damping * float(ri.dot(ri)) / (task.gain * task.gain)
        self._diagonal += mu
        np.dot(M.T, r, out=g)
        np.negative(g, out=g)
        if self.equalities.tasks:
            A, b = self.equalities.velocity(state)
        else:
            A, b = self._empty_rows, self._empty
        lb, ub, box_blocks = self.boxes.fill(state, dt)
        if self.inequalities:
            (C, l, u), in_blocks = self.inequalities.fill(state, dt)
        else:
            C, l, u, in_blocks = self._empty_rows, self._empty, self._empty, []
        # H: sums of J^T W J (weights >= 0) and the damping: convex by construction
        return QPProblem(
            H, g, A, b, C, l, u, lb, ub, self._eq_blocks, in_blocks, box_blocks, convex=True
        )


__all__ = [
    "BoxStack",
    "InequalityStack",
    "TaskRowStack",
    "WeightedQPBuilder",
    "combine_bounds",
    "combine_boxes",
    "stack_inequalities",
]
