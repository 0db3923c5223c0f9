"""Path optimization (KOMO-style): a whole path as one Gauss-Newton problem (slides 4:1-4:4).

The decision variables are the configurations ``q_1:T`` (``q_0`` and a prefix
``q_-k:-1`` are given). The cost of slide 4:2,

    f(q_1:T) = sum_t |Psi_t(q_t-k, .., q_t)|^2 + sum_t |Phi_t(q_t)|^2,

has control terms ``Psi_t`` of order ``k`` (slide 4:3: velocity ``q_t - q_t-1``, acceleration
``q_t - 2 q_t-1 + q_t-2``, jerk ``q_t - 3 q_t-1 + 3 q_t-2 - q_t-3``) and task terms ``Phi_t``
built from any :class:`~taskspace.features.feature.Feature` (through a
:class:`~taskspace.tasks.Task`) at chosen time slices. Hard constraints (slide 4:4,
"constrained optimization") are equalities ``h_t(q_t) = 0`` (a task's residual, e.g. a final
pose) and inequalities ``lower <= phi(q_t) <= upper`` (a
:class:`~taskspace.constraints.FeatureBounds`, e.g. collision distances ``>= margin``) plus
the joint limits. They are handled by an augmented Lagrangian outer loop,

    L(x) = f(x) + rho |h + lambda_h / (2 rho)|^2 + rho |[g + lambda_g / (2 rho)]_+|^2,
    lambda_h <- lambda_h + 2 rho h,   lambda_g <- [lambda_g + 2 rho g]_+,

which keeps the problem a sum of squares. The inner solver is Levenberg-Marquardt on that
sum of squares; the pseudo-Hessian ``J^T J`` couples ``q_s, q_t`` only for ``|s - t| <= k``
and is assembled and factorized as a symmetric banded matrix
(:class:`~taskspace.trajopt.banded.SymmetricBlockBanded`), so an iteration costs ``O(T)``.

Supported robots: configuration spaces that are vector spaces (``nq == nv``: fixed-base arms
with revolute and prismatic joints). Floating bases and continuous joints (unit quaternions
or unit complex numbers in ``q``) are rejected with an error.
"""

from __future__ import annotations

import enum
import logging
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray, as_matrix, check_positive
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.trajopt.banded import SymmetricBlockBanded

if TYPE_CHECKING:
    import scipy.sparse

    from taskspace.constraints.feature_bounds import FeatureBounds
    from taskspace.model.robot import Robot
    from taskspace.model.state import State
    from taskspace.tasks import Task

logger = logging.getLogger(__name__)

FINITE_DIFFERENCE_COEFFICIENTS: dict[int, tuple[float, ...]] = {
    1: (1.0, -1.0),
    2: (1.0, -2.0, 1.0),
    3: (1.0, -3.0, 3.0, -1.0),
}
"""Coefficients ``c_j`` of ``Psi_t = sum_j c_j q_t-j`` for the orders k = 1, 2, 3 (slide 4:3)."""

Times = int | Sequence[int] | None


# ---------------------------------------------------------------------- problem terms
@dataclass(frozen=True, eq=False)
class PathCost:
    """Task cost ``rho |phi(q_t) - y*|^2`` at the time slices ``times`` (the ``Phi_t`` of 4:2).

    Attributes:
        task: feature, target and weight ``rho`` (the task's gain and priority are ignored).
        times: slices ``t`` in ``1..T`` (negative values count from the end: ``-1`` is ``T``);
            ``None`` means every slice.
    """

    task: Task
    times: Times = None


@dataclass(frozen=True, eq=False)
class PathEquality:
    """Hard equality ``h_t = sqrt(rho) (phi(q_t) - y*) = 0`` at ``times`` (e.g. a final pose).

    Attributes:
        task: feature, target and weight ``rho`` (scales the constraint rows).
        times: as in :class:`PathCost`.
    """

    task: Task
    times: Times = -1


@dataclass(frozen=True, eq=False)
class PathInequality:
    """Hard inequality ``lower <= phi(q_t) <= upper`` at ``times``.

    Example: ``PathInequality(FeatureBounds(CollisionDistance(robot, pairs), 0.02, np.inf))``
    keeps every selected pair at least 2 cm apart along the whole path.

    Attributes:
        bounds: the feature and its bounds (the same object the differential IK uses).
        times: as in :class:`PathCost`.
    """

    bounds: FeatureBounds
    times: Times = None


# ---------------------------------------------------------------------- options and result
class PathOptimizationStatus(enum.Enum):
    """Outcome of :func:`optimize_path`."""

    CONVERGED = "converged"
    """Inner iterations converged and every constraint holds within tolerance."""
    MAX_ITERATIONS = "max_iterations"
    """The iteration budget ran out before convergence."""
    INFEASIBLE = "infeasible"
    """The penalty reached its maximum with constraints still violated."""


@dataclass(frozen=True, kw_only=True)
class PathOptimizationOptions:
    """Settings of :func:`optimize_path`.

    Attributes:
        max_iterations: total Levenberg-Marquardt iterations (linear solves), all outer
            iterations together.
        max_outer_iterations: augmented Lagrangian (multiplier) updates.
        constraint_tolerance: largest accepted constraint violation, in the constraint's own
            units ([m] for distances and positions, [rad] for angles and joint limits).
        step_tolerance: the inner loop stops when ``max |dq| <`` this [rad or m].
        cost_tolerance: ... or when the relative decrease of the objective is below this.
        initial_penalty: initial penalty ``rho`` of the augmented Lagrangian.
        penalty_growth: factor applied to ``rho`` when the violation did not shrink enough.
        violation_decrease: ``rho`` grows unless the violation shrank by this factor.
        max_penalty: largest ``rho``.
        initial_damping: Levenberg-Marquardt damping relative to ``max diag(J^T J)``.
        max_step: largest change of one joint in one iteration [rad or m] (trust region).
        repair: push the slices of the initial path that violate an inequality (e.g. that are
            in collision) out along the constraint gradient before optimizing.
        repair_iterations: Gauss-Newton projection steps per slice during the repair.
    """

    max_iterations: int = 200
    max_outer_iterations: int = 30
    constraint_tolerance: float = 1e-4
    step_tolerance: float = 1e-4
    cost_tolerance: float = 1e-3
    initial_penalty: float = 1e4
    penalty_growth: float = 10.0
    violation_decrease: float = 0.25
    max_penalty: float = 1e9
    initial_damping: float = 1e-6
    max_step: float = 1.0
    repair: bool = True
    repair_iterations: int = 20


@dataclass
class PathOptimizationResult:
    """Result of :func:`optimize_path`.

    Attributes:
        success: converged with every constraint within ``constraint_tolerance``.
        status: see :class:`PathOptimizationStatus`.
        path: configurations ``q_0..q_T``, shape (T + 1, nq).
        iterations: Levenberg-Marquardt iterations (linear solves, accepted or not).
        outer_iterations: augmented Lagrangian multiplier updates.
        cost: final cost ``f`` (control + task costs, without constraint terms).
        max_violation: final largest constraint violation (units of the constraints).
        violations: final largest violation per constraint (by name; ``"joint limits"``).
        cost_history: ``f`` after each accepted iteration (first entry: initial path).
        violation_history: largest constraint violation after each accepted iteration.
        penalty: final penalty ``rho``.
        repaired_slices: slices of the initial path moved by the repair.
        solve_time: wall time of the whole call [s].
        evaluation_time: time spent evaluating features and assembling ``J^T J`` [s].
        linear_solve_time: time spent in the banded Cholesky solves [s].
    """

    success: bool
    status: PathOptimizationStatus
    path: FloatArray
    iterations: int
    outer_iterations: int
    cost: float
    max_violation: float
    violations: dict[str, float]
    cost_history: list[float] = field(default_factory=list)
    violation_history: list[float] = field(default_factory=list)
    penalty: float = 0.0
    repaired_slices: int = 0
    solve_time: float = 0.0
    evaluation_time: float = 0.0
    linear_solve_time: float = 0.0

    @property
    def time_per_iteration(self) -> float:
        """Mean wall time of one iteration [s]."""
        return self.solve_time / max(self.iterations, 1)


@dataclass
class PathMultipliers:
    """Lagrange multipliers of the constraints of a :class:`PathProblem`, per slice.

    Attributes:
        equality: ``lambda_h`` per slice (1..T), one entry per equality row of the slice.
        inequality: ``lambda_g >= 0`` per slice, one entry per inequality row of the slice
            (feature bounds: lower rows then upper rows per term, then the joint limits).
    """

    equality: list[FloatArray]
    inequality: list[FloatArray]


# ---------------------------------------------------------------------- the problem
@dataclass
class _SliceTerms:
    costs: list[Task] = field(default_factory=list)
    equalities: list[Task] = field(default_factory=list)
    inequalities: list[FeatureBounds] = field(default_factory=list)
    n_cost: int = 0
    n_eq: int = 0
    n_in: int = 0


@dataclass
class _SliceValues:
    """Raw values of one slice: weighted cost residuals, equality values, inequality values."""

    e: FloatArray
    h: FloatArray
    g: FloatArray


@dataclass
class _Evaluation:
    """Everything computed at one path (features once; residual rows per penalty)."""

    path: FloatArray
    states: list[State]
    control: dict[int, FloatArray]
    values: list[_SliceValues]
    rows: list[FloatArray] = field(default_factory=list)


class PathProblem:
    """A path optimization problem (slide 4:2) on ``T`` time slices.

    Args:
        robot: the robot (fixed base: ``nq == nv``).
        q_start: the given start configuration ``q_0`` (size nq).
        horizon: number ``T >= 1`` of optimized slices ``q_1..q_T``.
        costs: task costs.
        equalities: hard equality constraints.
        inequalities: hard inequality constraints.
        velocity_weight: weight ``w_1`` of the velocity cost (k = 1) [s / rad^2].
        acceleration_weight: weight ``w_2`` of the acceleration cost (k = 2) [s^3 / rad^2].
        jerk_weight: weight ``w_3`` of the jerk cost (k = 3) [s^5 / rad^2].
        duration: duration of the path [s]; the time step is ``dt = duration / T``.
        prefix: configurations ``q_-k..q_-1`` before the start, shape (m, nq) with
            ``m >= k`` (the last ``k`` rows are used); default: ``q_0`` repeated (start at
            rest).
        joint_limits: add the joint position limits as hard inequalities.

    The control term of order ``k`` is ``Psi_t = sqrt(w_k dt) / dt^k sum_j c_j q_t-j``
    (slide 4:3 scaled so that ``sum_t |Psi_t|^2 ~ w_k int |q^(k)(t)|^2 dt``: the weight means
    the same for every ``T``).

    Raises:
        InvalidInputError: bad horizon, weights, times, robot with a non-vector configuration
            space, or terms defined on another robot.
        ShapeError, NotFiniteError: bad ``q_start`` or ``prefix``.
    """

    def __init__(
        self,
        robot: Robot,
        q_start: Any,
        horizon: int,
        *,
        costs: Iterable[PathCost] = (),
        equalities: Iterable[PathEquality] = (),
        inequalities: Iterable[PathInequality] = (),
        velocity_weight: float = 0.0,
        acceleration_weight: float = 1.0,
        jerk_weight: float = 0.0,
        duration: float = 1.0,
        prefix: Any = None,
        joint_limits: bool = True,
    ) -> None:
        if robot.nq != robot.nv:
            raise InvalidInputError(
                f"path optimization supports robots whose configuration space is a vector space "
                f"(nq == nv); robot '{robot.name}' has nq={robot.nq}, nv={robot.nv} (floating "
                "base or continuous joints are not supported yet)"
            )
        if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
            raise InvalidInputError(f"horizon T must be an integer >= 1, got {horizon!r}")
        self.robot = robot
        self.horizon = T = int(horizon)
        self.nv = nv = robot.nv
        self.q_start = robot.check_configuration(q_start, "q_start")
        self.duration = check_positive(duration, "duration")
        self.dt = self.duration / T
        weights = {1: velocity_weight, 2: acceleration_weight, 3: jerk_weight}
        self.control_weights: dict[int, float] = {}
        for k, w in weights.items():
            wk = check_positive(w, f"weight of the order-{k} control cost", strict=False)
            if wk > 0:
                self.control_weights[k] = wk
        self.order = max(self.control_weights, default=0)
        self._scales = {
            k: math.sqrt(w * self.dt) / self.dt**k for k, w in self.control_weights.items()
        }
        if prefix is None:
            self.prefix = np.tile(self.q_start, (self.order, 1))
        else:
            pre = as_matrix(prefix, (None, robot.nq), "prefix")
            if pre.shape[0] < self.order:
                raise ShapeError("prefix", (self.order, robot.nq), pre.shape)
            self.prefix = pre[pre.shape[0] - self.order :].copy()
        self.costs = list(costs)
        self.equalities = list(equalities)
        self.inequalities = list(inequalities)
        self.joint_limits = bool(joint_limits)
        self._slices = [_SliceTerms() for _ in range(T)]
        for cost in self.costs:
            self._check_robot(cost.task.feature.robot, cost.task.name)
            _require_target(cost.task)
            for t in self._times(cost.times, cost.task.name):
                s = self._slices[t - 1]
                s.costs.append(cost.task)
                s.n_cost += cost.task.dim
        for eq in self.equalities:
            self._check_robot(eq.task.feature.robot, eq.task.name)
            _require_target(eq.task)
            for t in self._times(eq.times, eq.task.name):
                s = self._slices[t - 1]
                s.equalities.append(eq.task)
                s.n_eq += eq.task.dim
        for ineq in self.inequalities:
            self._check_robot(ineq.bounds.robot, ineq.bounds.name)
            for t in self._times(ineq.times, ineq.bounds.name):
                s = self._slices[t - 1]
                s.inequalities.append(ineq.bounds)
                s.n_in += 2 * ineq.bounds.feature.dim
        self._limit_v = robot.limited_joints_v if self.joint_limits else np.zeros(0, dtype=int)
        self._limit_q = robot.limited_joints_q if self.joint_limits else np.zeros(0, dtype=int)
        self._limit_low = robot.lower_limits[self._limit_q]
        self._limit_high = robot.upper_limits[self._limit_q]
        n_lim = self._limit_q.size
        self._n_limit_rows = 2 * n_lim
        self._limit_jacobian = np.zeros((2 * n_lim, nv))
        self._limit_jacobian[np.arange(n_lim), self._limit_v] = -1.0
        self._limit_jacobian[n_lim + np.arange(n_lim), self._limit_v] = 1.0
        self._control_band = self._build_control_band()
        self._states: list[State] = [robot.state(self.q_start) for _ in range(T)]
        self._trial_states: list[State] = [robot.state(self.q_start) for _ in range(T)]

    # ------------------------------------------------------------------ construction helpers
    def _check_robot(self, robot: Robot, name: str) -> None:
        if robot is not self.robot:
            raise InvalidInputError(
                f"term '{name}' is defined on robot '{robot.name}', not on the problem's robot "
                f"'{self.robot.name}' (same object required)"
            )

    def _times(self, times: Times, name: str) -> list[int]:
        T = self.horizon
        if times is None:
            return list(range(1, T + 1))
        raw = [times] if isinstance(times, (int, np.integer)) else list(times)
        out = []
        for t in raw:
            if isinstance(t, bool) or not isinstance(t, (int, np.integer)):
                raise InvalidInputError(f"times of '{name}' must be integers, got {t!r}")
            ti = int(t) + T + 1 if t < 0 else int(t)
            if not 1 <= ti <= T:
                raise InvalidInputError(
                    f"time slice {t} of '{name}' is outside 1..T = 1..{T} (negative values "
                    "count from the end; q_0 is fixed)"
                )
            out.append(ti)
        return sorted(set(out))

    def _build_control_band(self) -> FloatArray:
        """Lower band (k + 1, T) of ``sum_k s_k^2 C_k^T C_k`` (per joint; ``kron I_nv``)."""
        T, order = self.horizon, self.order
        band = np.zeros((order + 1, T))
        for k, scale in self._scales.items():
            c = FINITE_DIFFERENCE_COEFFICIENTS[k]
            t = np.arange(1, T + 1)
            for j1 in range(k + 1):
                for j2 in range(j1, k + 1):
                    s2 = t - j2  # variable index (1-based) of the later-in-column factor
                    valid = s2 >= 1
                    np.add.at(band[j2 - j1], s2[valid] - 1, scale**2 * c[j1] * c[j2])
        return band

    # ------------------------------------------------------------------ layout
    @property
    def bandwidth(self) -> int:
        """Rows of the band storage of ``J^T J``: ``(k + 1) nv``."""
        return (self.order + 1) * self.nv

    def zero_multipliers(self) -> PathMultipliers:
        """Multipliers all zero (the start of the augmented Lagrangian)."""
        return PathMultipliers(
            [np.zeros(s.n_eq) for s in self._slices],
            [np.zeros(s.n_in + self._n_limit_rows) for s in self._slices],
        )

    def check_path(self, path: Any, name: str = "path") -> FloatArray:
        """Validate a full path ``q_0..q_T``: shape (T + 1, nq), finite."""
        arr = as_matrix(path, (self.horizon + 1, self.robot.nq), name)
        return arr.copy()

    # ------------------------------------------------------------------ evaluation
    def _update_states(self, path: FloatArray, states: list[State]) -> None:
        for t in range(self.horizon):
            states[t].update(path[t + 1], validate=False)

    def _control_residuals(self, path: FloatArray) -> dict[int, FloatArray]:
        """``R_k[t - 1] = s_k sum_j c_j q_t-j`` for t = 1..T, each (T, nv)."""
        ext = np.vstack([self.prefix, path]) if self.order else path
        out = {}
        for k, scale in self._scales.items():
            out[k] = scale * np.diff(ext[self.order - k :], n=k, axis=0)[1:]
        return out

    def _slice_values(self, t: int, state: State) -> _SliceValues:
        """Feature values of slice ``t`` (1..T): cost residuals, ``h`` and ``g``."""
        terms = self._slices[t - 1]
        e = np.empty(terms.n_cost)
        row = 0
        for task in terms.costs:
            d = task.dim
            e[row : row + d] = task.sqrt_weight * task.feature.residual(state, task.target)
            row += d
        h = np.empty(terms.n_eq)
        row = 0
        for task in terms.equalities:
            d = task.dim
            h[row : row + d] = task.sqrt_weight * task.feature.residual(state, task.target)
            row += d
        g = np.empty(terms.n_in + self._n_limit_rows)
        row = 0
        for bounds in terms.inequalities:
            d = bounds.feature.dim
            y = np.asarray(bounds.feature.value(state), dtype=float)
            g[row : row + d] = bounds.lower - y
            g[row + d : row + 2 * d] = y - bounds.upper
            row += 2 * d
        if self._n_limit_rows:
            qi = state.q[self._limit_q]
            m = self._n_limit_rows // 2
            g[row : row + m] = self._limit_low - qi
            g[row + m :] = qi - self._limit_high
        return _SliceValues(e, h, g)

    def _slice_residual(
        self, t: int, values: _SliceValues, penalty: float, multipliers: PathMultipliers
    ) -> FloatArray:
        """Rows of slice ``t``: ``e``, ``sqrt(rho)(h + lambda/2rho)``, ``sqrt(rho)[g + ..]_+``."""
        sqrt_rho = math.sqrt(penalty)
        half = 0.5 / penalty
        shifted = values.g + half * multipliers.inequality[t - 1]
        return np.concatenate(
            [
                values.e,
                sqrt_rho * (values.h + half * multipliers.equality[t - 1]),
                sqrt_rho * np.maximum(shifted, 0.0),
            ]
        )

    def _slice_jacobian(
        self,
        t: int,
        state: State,
        values: _SliceValues,
        penalty: float,
        multipliers: PathMultipliers,
    ) -> FloatArray:
        """Jacobian (rows x nv) of :meth:`_slice_residual`; inactive inequality rows are 0."""
        terms = self._slices[t - 1]
        n = terms.n_cost + terms.n_eq + terms.n_in + self._n_limit_rows
        active = (values.g + (0.5 / penalty) * multipliers.inequality[t - 1]) > 0
        J = np.zeros((n, self.nv))
        if not (terms.n_cost or terms.n_eq or active.any()):
            return J
        sqrt_rho = math.sqrt(penalty)
        row = 0
        for task in terms.costs:
            d = task.dim
            J[row : row + d] = task.sqrt_weight * task.feature.residual_jacobian(state, task.target)
            row += d
        for task in terms.equalities:
            d = task.dim
            Je = task.feature.residual_jacobian(state, task.target)
            J[row : row + d] = (sqrt_rho * task.sqrt_weight) * Je
            row += d
        i = 0
        for bounds in terms.inequalities:
            d = bounds.feature.dim
            act = active[i : i + 2 * d]
            if act.any():
                Jy = bounds.feature.jacobian(state)
                J[row : row + d] = (-sqrt_rho * act[:d, None]) * Jy
                J[row + d : row + 2 * d] = (sqrt_rho * act[d:, None]) * Jy
            row += 2 * d
            i += 2 * d
        if self._n_limit_rows:
            J[row:] = (sqrt_rho * active[i:, None]) * self._limit_jacobian
        return J

    def _evaluate(self, path: FloatArray, states: list[State], update: bool = True) -> _Evaluation:
        """Feature values along ``path`` (kinematics in ``states``, updated unless told)."""
        if update:
            self._update_states(path, states)
        values = [self._slice_values(t, states[t - 1]) for t in range(1, self.horizon + 1)]
        return _Evaluation(path, states, self._control_residuals(path), values)

    def _set_rows(self, ev: _Evaluation, penalty: float, multipliers: PathMultipliers) -> None:
        ev.rows = [
            self._slice_residual(t + 1, v, penalty, multipliers) for t, v in enumerate(ev.values)
        ]

    def _jacobians(
        self, ev: _Evaluation, penalty: float, multipliers: PathMultipliers
    ) -> list[FloatArray]:
        return [
            self._slice_jacobian(t + 1, ev.states[t], v, penalty, multipliers)
            for t, v in enumerate(ev.values)
        ]

    def _assemble(
        self, ev: _Evaluation, penalty: float, multipliers: PathMultipliers
    ) -> tuple[SymmetricBlockBanded, FloatArray]:
        """``J^T J`` (banded) and ``J^T r`` at an evaluation (rows set for the penalty)."""
        T, nv = self.horizon, self.nv
        H = SymmetricBlockBanded(T, nv, self.order)
        H.add_scalar_band_kron(self._control_band)
        blocks = np.empty((T, nv, nv))
        grad = np.zeros((T, nv))
        for t, (J, r) in enumerate(zip(self._jacobians(ev, penalty, multipliers), ev.rows)):
            blocks[t] = J.T @ J
            grad[t] = J.T @ r
        H.add_diagonal_blocks(blocks)
        for k, R in ev.control.items():
            c = FINITE_DIFFERENCE_COEFFICIENTS[k]
            scale = self._scales[k]
            for j, cj in enumerate(c):
                # d Psi_t / d q_(t-j) = scale c_j I; q_s with s = t - j, t = s + j <= T
                grad[: T - j] += (scale * cj) * R[j:]
        return H, grad.ravel()

    @staticmethod
    def _objective(ev: _Evaluation) -> float:
        return float(
            sum(float(np.sum(R * R)) for R in ev.control.values())
            + sum(float(r @ r) for r in ev.rows)
        )

    @staticmethod
    def _cost(ev: _Evaluation) -> float:
        """``f``: control and task costs only."""
        total = sum(float(np.sum(R * R)) for R in ev.control.values())
        return total + sum(float(v.e @ v.e) for v in ev.values)

    @staticmethod
    def _max_violation(ev: _Evaluation) -> float:
        """``max(max |h|, max g, 0)`` over the whole path."""
        h = np.concatenate([v.h for v in ev.values])
        g = np.concatenate([v.g for v in ev.values])
        return max(float(np.max(np.abs(h), initial=0.0)), float(np.max(g, initial=0.0)))

    def _violations(self, ev: _Evaluation) -> dict[str, float]:
        out: dict[str, float] = {}
        for v, terms in zip(ev.values, self._slices):
            i = 0
            for task in terms.equalities:
                x = float(np.max(np.abs(v.h[i : i + task.dim]), initial=0.0))
                out[task.name] = max(out.get(task.name, 0.0), x)
                i += task.dim
            i = 0
            for bounds in terms.inequalities:
                d = 2 * bounds.feature.dim
                x = float(np.max(v.g[i : i + d], initial=0.0))
                out[bounds.name] = max(out.get(bounds.name, 0.0), x)
                i += d
            if self._n_limit_rows:
                x = float(np.max(v.g[i:], initial=0.0))
                out["joint limits"] = max(out.get("joint limits", 0.0), x)
        return out

    # ------------------------------------------------------------------ public inspection
    def residual(
        self, path: Any, *, penalty: float = 1.0, multipliers: PathMultipliers | None = None
    ) -> FloatArray:
        """The stacked residual ``r`` of the augmented Lagrangian, ``L = |r|^2``.

        Layout: control rows (per order k = 1, 2, 3 present; slice-major, T nv each), then
        per slice t = 1..T: task costs, equalities, inequalities (lower then upper rows per
        term), joint limits (lower then upper).

        Args:
            path: full path ``q_0..q_T``, shape (T + 1, nq).
            penalty: augmented Lagrangian penalty ``rho > 0``.
            multipliers: Lagrange multipliers (default zero).
        """
        p = self.check_path(path)
        rho = check_positive(penalty, "penalty")
        mult = multipliers or self.zero_multipliers()
        ev = self._evaluate(p, self._states)
        self._set_rows(ev, rho, mult)
        return np.concatenate([R.ravel() for R in ev.control.values()] + ev.rows)

    def residual_jacobian(
        self, path: Any, *, penalty: float = 1.0, multipliers: PathMultipliers | None = None
    ) -> scipy.sparse.csr_matrix:
        """Sparse Jacobian of :meth:`residual` with respect to ``q_1..q_T`` (T nv columns)."""
        import scipy.sparse

        p = self.check_path(path)
        rho = check_positive(penalty, "penalty")
        mult = multipliers or self.zero_multipliers()
        ev = self._evaluate(p, self._states)
        T, nv = self.horizon, self.nv
        blocks: list[Any] = []
        eye = scipy.sparse.identity(nv, format="csr")
        for k in ev.control:
            c = FINITE_DIFFERENCE_COEFFICIENTS[k]
            offsets = [j for j in range(k + 1) if T - j > 0]
            C = scipy.sparse.diags(
                [np.full(T - j, c[j]) for j in offsets], [-j for j in offsets], shape=(T, T)
            )
            blocks.append(self._scales[k] * scipy.sparse.kron(C, eye))
        jacobians = [scipy.sparse.csr_matrix(J) for J in self._jacobians(ev, rho, mult)]
        blocks.append(scipy.sparse.block_diag(jacobians, format="csr"))
        return scipy.sparse.vstack(blocks, format="csr")

    def normal_equations(
        self, path: Any, *, penalty: float = 1.0, multipliers: PathMultipliers | None = None
    ) -> tuple[SymmetricBlockBanded, FloatArray]:
        """The banded pseudo-Hessian ``J^T J`` and the gradient half ``J^T r`` at ``path``."""
        p = self.check_path(path)
        rho = check_positive(penalty, "penalty")
        mult = multipliers or self.zero_multipliers()
        ev = self._evaluate(p, self._states)
        self._set_rows(ev, rho, mult)
        return self._assemble(ev, rho, mult)

    def initial_path(self, waypoints: Any = None) -> FloatArray:
        """A full path ``q_0..q_T`` from waypoints (e.g. a planner's), resampled by arc length.

        Args:
            waypoints: configurations, shape (m, nq) with m >= 1; the first row is replaced by
                ``q_0`` when it differs (the path must start there). ``None``: ``q_0``
                repeated.

        Returns:
            Shape (T + 1, nq): the polyline through ``q_0`` and the waypoints sampled at
            ``T + 1`` points equally spaced in joint-space arc length.
        """
        T = self.horizon
        if waypoints is None:
            return np.tile(self.q_start, (T + 1, 1))
        pts = as_matrix(waypoints, (None, self.robot.nq), "initial path")
        if pts.shape[0] < 1:
            raise ShapeError("initial path", (-1, self.robot.nq), pts.shape)
        if pts.shape[0] == T + 1:
            out = pts.copy()
            out[0] = self.q_start
            return out
        if not np.allclose(pts[0], self.q_start):
            pts = np.vstack([self.q_start, pts])
        else:
            pts = pts.copy()
            pts[0] = self.q_start
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        if s[-1] <= 0.0:
            return np.tile(self.q_start, (T + 1, 1))
        keep = np.concatenate([[True], seg > 0])
        s, pts = s[keep], pts[keep]
        u = np.linspace(0.0, s[-1], T + 1)
        return np.column_stack([np.interp(u, s, pts[:, j]) for j in range(pts.shape[1])])


def _require_target(task: Task) -> None:
    if task.target is None:
        raise InvalidInputError(
            f"task '{task.name}' has no target: call task.set_target(...) before building the "
            "path problem"
        )


# ---------------------------------------------------------------------- solver
def _repair(problem: PathProblem, path: FloatArray, opts: PathOptimizationOptions) -> int:
    """Push slices violating an inequality out along its gradient (min-norm Gauss-Newton)."""
    if not problem.inequalities:
        return 0
    repaired = 0
    robot = problem.robot
    lo, hi = robot.lower_limits, robot.upper_limits
    for t in range(1, problem.horizon + 1):
        terms = problem._slices[t - 1]
        if not terms.inequalities:
            continue
        state = problem._states[t - 1]
        moved = False
        for _ in range(opts.repair_iterations):
            state.update(path[t], validate=False)
            rows, errs = [], []
            for bounds in terms.inequalities:
                y = np.asarray(bounds.feature.value(state), dtype=float)
                below = y < bounds.lower
                above = y > bounds.upper
                if below.any() or above.any():
                    Jy = bounds.feature.jacobian(state)
                    # aim a little inside the bounds to leave room for the smoothing
                    width = np.minimum(bounds.upper - bounds.lower, 1.0)
                    target = np.where(below, bounds.lower + 0.1 * width, bounds.upper - 0.1 * width)
                    sel = below | above
                    rows.append(Jy[sel])
                    errs.append((target - y)[sel])
            if not rows:
                break
            J = np.vstack(rows)
            e = np.concatenate(errs)
            dq = J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(J.shape[0]), e)
            dq *= min(1.0, opts.max_step / max(float(np.max(np.abs(dq))), 1e-12))
            path[t] = np.clip(path[t] + dq, lo, hi)
            moved = True
        repaired += moved
    return repaired


def optimize_path(
    problem: PathProblem,
    initial_path: Any = None,
    *,
    options: PathOptimizationOptions | None = None,
) -> PathOptimizationResult:
    """Solve a :class:`PathProblem` by augmented Lagrangian + banded Levenberg-Marquardt.

    Each inner iteration solves ``(J^T J + mu I) dx = -J^T r`` with the banded Cholesky
    factorization of :class:`~taskspace.trajopt.banded.SymmetricBlockBanded` (``O(T)``),
    accepts the step when the augmented Lagrangian decreases and adapts ``mu`` from the ratio
    of actual to predicted decrease (Nielsen's rule). When the inner loop stalls, the
    multipliers are updated (``lambda_h += 2 rho h``, ``lambda_g = [lambda_g + 2 rho g]_+``)
    and ``rho`` grows unless the violation shrank enough.

    Args:
        problem: the problem.
        initial_path: warm start: waypoints of shape (m, nq) (resampled to ``T + 1`` slices
            with :meth:`PathProblem.initial_path`), or ``None`` (``q_0`` repeated).
        options: settings.

    Returns:
        The result; ``success`` tells whether the path satisfies every constraint within
        ``options.constraint_tolerance``.

    Raises:
        ShapeError, NotFiniteError: bad ``initial_path``.
        SolverError: the banded factorization failed even with large damping.
    """
    opts = options or PathOptimizationOptions()
    t_start = time.perf_counter()
    path = problem.initial_path(initial_path)
    T, nv = problem.horizon, problem.nv
    repaired = _repair(problem, path, opts) if opts.repair else 0
    states = problem._states
    trial_states = problem._trial_states
    mult = problem.zero_multipliers()
    rho = opts.initial_penalty
    eval_time = 0.0
    solve_time = 0.0

    t0 = time.perf_counter()
    ev = problem._evaluate(path, states)
    problem._set_rows(ev, rho, mult)
    eval_time += time.perf_counter() - t0
    objective = problem._objective(ev)
    violation = problem._max_violation(ev)
    cost_history = [problem._cost(ev)]
    violation_history = [violation]
    mu = -1.0
    nu = 2.0
    iterations = 0
    outer = 0
    previous_violation = math.inf
    status = PathOptimizationStatus.MAX_ITERATIONS
    inner_done = False
    H: SymmetricBlockBanded | None = None
    grad = np.zeros(T * nv)
    while iterations < opts.max_iterations:
        if inner_done:
            inner_done = False
            if violation <= opts.constraint_tolerance:
                status = PathOptimizationStatus.CONVERGED
                break
            if outer >= opts.max_outer_iterations:
                break
            outer += 1
            for t, v in enumerate(ev.values):
                mult.equality[t] += 2.0 * rho * v.h
                np.maximum(mult.inequality[t] + 2.0 * rho * v.g, 0.0, out=mult.inequality[t])
            if violation > opts.violation_decrease * previous_violation:
                if rho >= opts.max_penalty:
                    status = PathOptimizationStatus.INFEASIBLE
                    break
                rho = min(rho * opts.penalty_growth, opts.max_penalty)
            previous_violation = violation
            problem._set_rows(ev, rho, mult)
            objective = problem._objective(ev)
            H = None
            mu = -1.0
            nu = 2.0
        if H is None:
            t0 = time.perf_counter()
            H, grad = problem._assemble(ev, rho, mult)
            eval_time += time.perf_counter() - t0
            if mu < 0:
                mu = opts.initial_damping * float(np.max(H.ab[0]))
        iterations += 1
        t0 = time.perf_counter()
        damped = H.copy()
        damped.add_diagonal(mu)
        dx = damped.solve(-grad)
        solve_time += time.perf_counter() - t0
        largest = float(np.max(np.abs(dx))) if dx.size else 0.0
        if largest > opts.max_step:
            dx *= opts.max_step / largest
            largest = opts.max_step
        # predicted decrease of |r + J dx|^2: -(2 g.dx + dx.JTJ.dx)
        predicted = -(2.0 * float(grad @ dx) + float(dx @ H.matvec(dx)))
        trial = path.copy()
        trial[1:] += dx.reshape(T, nv)
        t0 = time.perf_counter()
        trial_ev = problem._evaluate(trial, trial_states)
        problem._set_rows(trial_ev, rho, mult)
        eval_time += time.perf_counter() - t0
        trial_objective = problem._objective(trial_ev)
        decrease = objective - trial_objective
        if decrease > 0 and predicted > 0:
            ratio = decrease / predicted
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
            nu = 2.0
            path, ev, objective = trial, trial_ev, trial_objective
            states, trial_states = trial_states, states
            H = None
            violation = problem._max_violation(ev)
            cost_history.append(problem._cost(ev))
            violation_history.append(violation)
            if largest < opts.step_tolerance or decrease < opts.cost_tolerance * objective:
                inner_done = True
        else:
            mu *= nu
            nu *= 2.0
            if largest < opts.step_tolerance or not math.isfinite(mu) or mu > 1e20:
                inner_done = True
    if status is PathOptimizationStatus.MAX_ITERATIONS and inner_done:
        if violation <= opts.constraint_tolerance:
            status = PathOptimizationStatus.CONVERGED
    result = PathOptimizationResult(
        success=status is PathOptimizationStatus.CONVERGED,
        status=status,
        path=path,
        iterations=iterations,
        outer_iterations=outer,
        cost=problem._cost(ev),
        max_violation=violation,
        violations=problem._violations(ev),
        cost_history=cost_history,
        violation_history=violation_history,
        penalty=rho,
        repaired_slices=repaired,
        solve_time=time.perf_counter() - t_start,
        evaluation_time=eval_time,
        linear_solve_time=solve_time,
    )
    logger.debug(
        "path optimization: %s after %d iterations (%d outer), violation %.3g, cost %.4g",
        status.value,
        iterations,
        outer,
        violation,
        result.cost,
    )
    return result
