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

Thread safety: a :class:`PathProblem` serializes its evaluations with a lock (see there); the
terms, options and statuses are immutable values; :class:`PathMultipliers` and
:class:`PathOptimizationResult` are plain result data, not locked.
"""

from __future__ import annotations

import enum
import functools
import inspect
import logging
import math
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import FloatArray, as_matrix, check_count, check_positive
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.model.versioning import ModelFollower
from taskspace.qp.rows import TaskRowStack
from taskspace.trajopt.banded import SymmetricBlockBanded

if TYPE_CHECKING:
    import scipy.sparse

    from taskspace.constraints.feature_bounds import FeatureBounds
    from taskspace.features.feature import Feature
    from taskspace.model.robot import Robot
    from taskspace.model.state import State
    from taskspace.tasks import Task

logger = logging.getLogger(__name__)

MAX_HORIZON = 100_000
"""Largest number of time slices ``T`` of a :class:`PathProblem`."""

MIN_CONSTRAINT_TOLERANCE = 1e-12
"""Smallest :attr:`PathOptimizationOptions.constraint_tolerance`: constraint values carry the
rounding of the features' kinematics (~1e-16 relative), which a tolerance of 0 never accepted."""

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
    """The iteration budget (``max_iterations`` or ``max_outer_iterations``) ran out before
    convergence."""
    INFEASIBLE = "infeasible"
    """The penalty reached its maximum with constraints still violated (and the violation no
    longer shrinking). With steps kept tiny by the options (``max_step`` or
    ``initial_damping`` far from the defaults) the path may not have moved enough to tell."""


@dataclass(frozen=True, kw_only=True)
class PathOptimizationOptions:
    """Settings of :func:`optimize_path`.

    Attributes:
        max_iterations: total Levenberg-Marquardt iterations (linear solves), all outer
            iterations together; 0 returns the initial (repaired) path, status
            ``MAX_ITERATIONS``.
        max_outer_iterations: augmented Lagrangian (multiplier) updates; 0 stops after the
            first inner loop (status ``CONVERGED`` only if it already meets the tolerance,
            else ``MAX_ITERATIONS``).
        constraint_tolerance: largest accepted constraint violation, in the constraint's own
            units ([m] for distances and positions, [rad] for angles and joint limits); at
            least :data:`MIN_CONSTRAINT_TOLERANCE` (1e-12).
        step_tolerance: the inner loop stops when ``max |dq| <`` this [rad or m] (0: never
            on the step; a value above ``max_step`` ends every inner loop after one step).
        cost_tolerance: ... or when the relative decrease of the objective is below this
            (0: never on the decrease).
        initial_penalty: initial penalty ``rho`` of the augmented Lagrangian (> 0).
        penalty_growth: factor applied to ``rho`` when the violation did not shrink enough
            (> 1).
        violation_decrease: ``rho`` grows unless the violation shrank to this fraction of the
            previous outer iteration's, in ``(0, 1]``.
        max_penalty: largest ``rho``, at least ``initial_penalty`` (equal: a fixed penalty).
        initial_damping: Levenberg-Marquardt damping relative to ``max diag(J^T J)`` (> 0:
            after a rejected step the damping grows by factors from it).
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


@dataclass(eq=False)
class _Term:
    """A cost, equality or inequality term and the slices it acts on.

    Attributes:
        feature: the term's feature.
        dim: rows per slice (``feature.dim``; inequalities have ``2 dim``: lower, upper).
        slices: slice indices (0-based: slice ``t`` is ``slices[i] + 1``), increasing.
        offsets: first row of the term inside the slice's cost, equality or inequality block
            (the per-slice layout of :meth:`PathProblem.residual` and of the multipliers).
        task: the task (costs and equalities).
        bounds: the bounds (inequalities).
        row_jacobian: ``feature.jacobian`` accepts ``rows=`` (computes selected rows only).
    """

    feature: Feature
    dim: int
    slices: list[int]
    offsets: list[int]
    task: Task | None = None
    bounds: FeatureBounds | None = None
    row_jacobian: bool = False

    @property
    def slice_array(self) -> npt.NDArray[np.intp]:
        """:attr:`slices` as an integer array."""
        return np.asarray(self.slices, dtype=np.intp)

    @property
    def name(self) -> str:
        """Name of the task or bounds."""
        item = self.task if self.task is not None else self.bounds
        return item.name if item is not None else self.feature.name


@dataclass
class _TermMultipliers:
    """Multipliers per term (the solver's layout of :class:`PathMultipliers`).

    Attributes:
        equality: per equality term, shape (slices, dim).
        inequality: per inequality term, shape (slices, 2 dim): lower rows then upper rows.
        limits: joint limits, shape (T, 2 m): lower rows then upper rows.
    """

    equality: list[FloatArray]
    inequality: list[FloatArray]
    limits: FloatArray


@dataclass
class _CandidateRows:
    """Inactive inequality rows kept in the step's model as hinges ``[r + j dx]_+^2``.

    Attributes:
        slices: slice index (0-based) of each row, shape (k,).
        jacobian: the rows ``j`` of the residual Jacobian (signed, scaled by ``sqrt(rho)``),
            shape (k, nv).
        residual: the unclipped residual values ``r = sqrt(rho)(g + lambda / 2 rho) <= 0``,
            shape (k,).
        term: index of the inequality term of each row, shape (k,).
        index: index of the row's slice among the term's slices, shape (k,).
        row: row inside the term's slice block (lower rows, then upper rows), shape (k,).
    """

    slices: npt.NDArray[np.intp]
    jacobian: FloatArray
    residual: FloatArray
    term: npt.NDArray[np.intp]
    index: npt.NDArray[np.intp]
    row: npt.NDArray[np.intp]

    @property
    def size(self) -> int:
        """Number of rows."""
        return int(self.slices.size)

    def linearized(self, dx: FloatArray) -> FloatArray:
        """``r + j dx`` for a step ``dx`` of shape (T, nv)."""
        if not self.size:
            return np.zeros(0)
        return self.residual + np.einsum("ij,ij->i", self.jacobian, dx[self.slices])


_NO_INDEX = np.zeros(0, dtype=np.intp)
_NO_CANDIDATES = _CandidateRows(
    _NO_INDEX, np.zeros((0, 0)), np.zeros(0), _NO_INDEX, _NO_INDEX, _NO_INDEX
)


@dataclass
class _Evaluation:
    """Everything computed at one path (features once; residual rows per penalty).

    Values are stored per term, one row per slice of the term: ``costs`` the weighted cost
    residuals ``e``, ``eqs`` the equality values ``h``, ``ineqs`` the inequality values
    ``g`` (lower rows ``lower - phi``, then upper rows ``phi - upper``), ``limits`` the
    joint-limit values (T, 2 m). The ``*_rows`` are the augmented Lagrangian residual rows
    for the current penalty and multipliers (set by :meth:`PathProblem._set_rows`).
    """

    path: FloatArray
    states: list[State]
    control: dict[int, FloatArray]
    costs: list[FloatArray]
    eqs: list[FloatArray]
    ineqs: list[FloatArray]
    limits: FloatArray
    eq_rows: list[FloatArray] = field(default_factory=list)
    ineq_rows: list[FloatArray] = field(default_factory=list)
    limit_rows: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))


def _locked(method: Any) -> Any:
    """Run a :class:`PathProblem` method under the problem's lock (its states are shared)."""

    @functools.wraps(method)
    def wrapper(self: PathProblem, *args: Any, **kwargs: Any) -> Any:
        with self._lock:
            return method(self, *args, **kwargs)

    return wrapper


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
        joint_limits: add the joint position limits as hard inequalities (the robot's
            current ones: after :meth:`Robot.set_limits` the next evaluation uses the new
            limits).

    The control term of order ``k`` is ``Psi_t = sqrt(w_k dt) / dt^k sum_j c_j q_t-j``
    (slide 4:3 scaled so that ``sum_t |Psi_t|^2 ~ w_k int |q^(k)(t)|^2 dt``: the weight means
    the same for every ``T``).

    Thread safety: a problem owns its kinematic workspace; :func:`optimize_path`,
    :meth:`residual`, :meth:`residual_jacobian` and :meth:`normal_equations` on one problem
    from several threads run one at a time (a lock). Build one problem per thread to run them
    in parallel.

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
        if horizon > MAX_HORIZON:  # two States per slice: 10**9 slices ran for ever
            raise InvalidInputError(
                f"horizon T = {horizon:,} exceeds {MAX_HORIZON:,} slices (each slice holds two "
                "kinematic states); use fewer slices"
            )
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
        self._scales = {}
        for k, w in self.control_weights.items():
            try:
                scale = math.sqrt(w * self.dt) / self.dt**k
            except (ZeroDivisionError, OverflowError):  # dt**k underflowed or overflowed
                scale = math.nan
            if not (math.isfinite(scale) and scale > 0.0):
                raise InvalidInputError(
                    f"the order-{k} control cost scale sqrt(w dt) / dt^{k} with w = {w:g}, "
                    f"dt = duration / T = {self.dt:g} s is not a positive float64; choose a "
                    "duration and weight in a representable range (e.g. seconds, weights near 1)"
                )
            self._scales[k] = scale
        if prefix is None:
            self.prefix = np.tile(self.q_start, (self.order, 1))
        else:
            pre = as_matrix(prefix, (None, robot.nq), "prefix")
            if pre.shape[0] < self.order:
                raise ShapeError("prefix", (self.order, robot.nq), pre.shape)
            self.prefix = pre[pre.shape[0] - self.order :].copy()
        self.costs = _terms(costs, PathCost, "costs")
        self.equalities = _terms(equalities, PathEquality, "equalities")
        self.inequalities = _terms(inequalities, PathInequality, "inequalities")
        self.joint_limits = bool(joint_limits)
        self._slices = [_SliceTerms() for _ in range(T)]
        self._cost_terms: list[_Term] = []
        self._eq_terms: list[_Term] = []
        self._ineq_terms: list[_Term] = []
        for cost in self.costs:
            self._check_robot(cost.task.feature.robot, cost.task.name)
            _require_target(cost.task)
            term = _Term(cost.task.feature, cost.task.dim, [], [], task=cost.task)
            for t in self._times(cost.times, cost.task.name):
                s = self._slices[t - 1]
                term.slices.append(t - 1)
                term.offsets.append(s.n_cost)
                s.costs.append(cost.task)
                s.n_cost += cost.task.dim
            self._cost_terms.append(term)
        for eq in self.equalities:
            self._check_robot(eq.task.feature.robot, eq.task.name)
            _require_target(eq.task)
            term = _Term(eq.task.feature, eq.task.dim, [], [], task=eq.task)
            for t in self._times(eq.times, eq.task.name):
                s = self._slices[t - 1]
                term.slices.append(t - 1)
                term.offsets.append(s.n_eq)
                s.equalities.append(eq.task)
                s.n_eq += eq.task.dim
            self._eq_terms.append(term)
        for ineq in self.inequalities:
            self._check_robot(ineq.bounds.robot, ineq.bounds.name)
            feature = ineq.bounds.feature
            term = _Term(
                feature,
                feature.dim,
                [],
                [],
                bounds=ineq.bounds,
                row_jacobian=_accepts_rows(feature),
            )
            for t in self._times(ineq.times, ineq.bounds.name):
                s = self._slices[t - 1]
                term.slices.append(t - 1)
                term.offsets.append(s.n_in)
                s.inequalities.append(ineq.bounds)
                s.n_in += 2 * feature.dim
            self._ineq_terms.append(term)
        # the joint-limit rows follow the robot (rebuilt after Robot.set_limits)
        self._follower = ModelFollower(robot, "PathProblem", self._derive_limits)
        self._control_band = self._build_control_band()
        # the Gauss-Newton rows of each slice's task costs and equalities, stacked by the
        # stacking layer in the slice's row layout (term offsets)
        self._cost_rows = [TaskRowStack(s.costs, nv) for s in self._slices]
        self._eq_rows = [TaskRowStack(s.equalities, nv) for s in self._slices]
        self._eq_slices = [t for t, s in enumerate(self._slices) if s.n_eq]
        self._states: list[State] = [robot.state(self.q_start) for _ in range(T)]
        self._trial_states: list[State] = [robot.state(self.q_start) for _ in range(T)]
        # the states above are the problem's workspace: two threads optimizing (or evaluating)
        # one problem at once mixed their kinematics (paths 1.5e-5 rad off the sequential
        # result); every public entry point holds this lock
        self._lock = threading.RLock()

    # ------------------------------------------------------------------ construction helpers
    def _derive_limits(self) -> None:
        """The joint-limit rows from the robot's current limits."""
        robot, nv = self.robot, self.robot.nv
        self._limit_v = robot.limited_joints_v if self.joint_limits else np.zeros(0, dtype=int)
        self._limit_q = robot.limited_joints_q if self.joint_limits else np.zeros(0, dtype=int)
        self._limit_low = robot.lower_limits[self._limit_q]
        self._limit_high = robot.upper_limits[self._limit_q]
        n_lim = self._limit_q.size
        self._n_limit_rows = 2 * n_lim
        self._limit_jacobian = np.zeros((2 * n_lim, nv))
        self._limit_jacobian[np.arange(n_lim), self._limit_v] = -1.0
        self._limit_jacobian[n_lim + np.arange(n_lim), self._limit_v] = 1.0

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
        raw: list[Any]
        if isinstance(times, np.ndarray) and times.ndim == 0:
            raw = [times.item()]
        elif isinstance(times, Iterable) and not isinstance(times, (str, bytes)):
            raw = list(times)
        else:  # a scalar (2.5 was a bare "TypeError: 'float' object is not iterable")
            raw = [times]
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
        self._follower.sync()
        return PathMultipliers(
            [np.zeros(s.n_eq) for s in self._slices],
            [np.zeros(s.n_in + self._n_limit_rows) for s in self._slices],
        )

    def check_path(self, path: Any, name: str = "path") -> FloatArray:
        """Validate a full path ``q_0..q_T``: shape (T + 1, nq), finite."""
        self._follower.sync()
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

    def _evaluate(self, path: FloatArray, states: list[State], update: bool = True) -> _Evaluation:
        """Feature values along ``path`` (kinematics in ``states``, updated unless told).

        One feature call per term and slice; everything else is vectorized over the slices.
        """
        self._follower.sync()
        if update:
            self._update_states(path, states)
        costs = [_weighted_residuals(term, states) for term in self._cost_terms]
        eqs = [_weighted_residuals(term, states) for term in self._eq_terms]
        ineqs = []
        for term in self._ineq_terms:
            bounds = _bounds(term)
            value, d = term.feature.value, term.dim
            Y = np.array([value(states[t]) for t in term.slices], dtype=float)
            Y = Y.reshape(len(term.slices), d)
            G = np.empty((len(term.slices), 2 * d))
            np.subtract(bounds.lower, Y, out=G[:, :d])
            np.subtract(Y, bounds.upper, out=G[:, d:])
            ineqs.append(G)
        m = self._n_limit_rows // 2
        limits = np.empty((self.horizon, 2 * m))
        if m:
            Q = path[1:, self._limit_q]
            np.subtract(self._limit_low, Q, out=limits[:, :m])
            np.subtract(Q, self._limit_high, out=limits[:, m:])
        return _Evaluation(path, states, self._control_residuals(path), costs, eqs, ineqs, limits)

    def _term_multipliers(self, multipliers: PathMultipliers | None) -> _TermMultipliers:
        """Multipliers in the solver's per-term layout (zero if ``None``).

        Raises:
            ShapeError: a slice's multiplier vector has the wrong size.
        """
        self._follower.sync()
        T, n_lim = self.horizon, self._n_limit_rows
        if multipliers is None:
            return _TermMultipliers(
                [np.zeros((len(term.slices), term.dim)) for term in self._eq_terms],
                [np.zeros((len(term.slices), 2 * term.dim)) for term in self._ineq_terms],
                np.zeros((T, n_lim)),
            )
        if len(multipliers.equality) != T or len(multipliers.inequality) != T:
            raise ShapeError(
                "multipliers", (T,), (len(multipliers.equality), len(multipliers.inequality))
            )
        lam_eq = [np.asarray(lam, dtype=float).ravel() for lam in multipliers.equality]
        lam_in = [np.asarray(lam, dtype=float).ravel() for lam in multipliers.inequality]
        for t, s in enumerate(self._slices):
            if lam_eq[t].size != s.n_eq:
                raise ShapeError(
                    f"equality multipliers of slice {t + 1}", (s.n_eq,), lam_eq[t].shape
                )
            if lam_in[t].size != s.n_in + n_lim:
                raise ShapeError(
                    f"inequality multipliers of slice {t + 1}", (s.n_in + n_lim,), lam_in[t].shape
                )
        eq = [
            np.array(
                [lam_eq[t][o : o + term.dim] for t, o in zip(term.slices, term.offsets)]
            ).reshape(len(term.slices), term.dim)
            for term in self._eq_terms
        ]
        ineq = [
            np.array(
                [lam_in[t][o : o + 2 * term.dim] for t, o in zip(term.slices, term.offsets)]
            ).reshape(len(term.slices), 2 * term.dim)
            for term in self._ineq_terms
        ]
        limits = np.array([lam[lam.size - n_lim :] for lam in lam_in]).reshape(T, n_lim)
        return _TermMultipliers(eq, ineq, limits)

    def _set_rows(self, ev: _Evaluation, penalty: float, multipliers: _TermMultipliers) -> None:
        """Residual rows ``sqrt(rho)(h + lambda/2rho)``, ``sqrt(rho)[g + lambda/2rho]_+``."""
        sqrt_rho = math.sqrt(penalty)
        half = 0.5 / penalty
        ev.eq_rows = [sqrt_rho * (h + half * lam) for h, lam in zip(ev.eqs, multipliers.equality)]
        ev.ineq_rows = [
            sqrt_rho * np.maximum(g + half * lam, 0.0)
            for g, lam in zip(ev.ineqs, multipliers.inequality)
        ]
        ev.limit_rows = sqrt_rho * np.maximum(ev.limits + half * multipliers.limits, 0.0)

    def _update_multipliers(
        self, ev: _Evaluation, penalty: float, multipliers: _TermMultipliers
    ) -> None:
        """``lambda_h += 2 rho h``, ``lambda_g = [lambda_g + 2 rho g]_+`` (in place)."""
        two_rho = 2.0 * penalty
        for lam, h in zip(multipliers.equality, ev.eqs):
            lam += two_rho * h
        for lam, g in zip(multipliers.inequality, ev.ineqs):
            np.maximum(lam + two_rho * g, 0.0, out=lam)
        lim = multipliers.limits
        np.maximum(lim + two_rho * ev.limits, 0.0, out=lim)

    def _assemble(
        self,
        ev: _Evaluation,
        penalty: float,
        multipliers: _TermMultipliers,
        watch: list[npt.NDArray[np.bool_]] | None = None,
    ) -> tuple[SymmetricBlockBanded, FloatArray, _CandidateRows]:
        """``J^T J`` (banded) and ``J^T r`` at an evaluation (rows set for the penalty).

        Feature Jacobians are computed only where rows are nonzero: every slice of a cost or
        equality term, the active rows of inequalities (``rows=`` when the feature supports
        it); joint-limit rows are unit rows, added to the diagonal directly.

        ``watch`` (per inequality term, the mask of its (slices, 2 dim) rows) selects
        inactive rows whose linearization is returned as :class:`_CandidateRows` (not added
        to ``J^T J``).
        """
        T, nv = self.horizon, self.nv
        states = ev.states
        blocks = np.zeros((T, nv, nv))
        grad = np.zeros((T, nv))
        # task costs: per slice, rows sqrt(rho) J and sqrt(rho) e of its tasks
        for t, stack in enumerate(self._cost_rows):
            if stack.size:
                J, E = stack.residual(states[t])
                JT = J.T
                blocks[t] += JT.dot(J)
                grad[t] += JT.dot(E)
        sqrt_rho = math.sqrt(penalty)
        if self._eq_slices:
            # equalities: rows sqrt(rho_AL) sqrt(rho) J against the shifted rows R
            R_slices = [np.empty(s.n_eq) for s in self._slices]
            for term, R in zip(self._eq_terms, ev.eq_rows):
                d = term.dim
                for i, (t, o) in enumerate(zip(term.slices, term.offsets)):
                    R_slices[t][o : o + d] = R[i]
            for t in self._eq_slices:
                J = sqrt_rho * self._eq_rows[t].residual(states[t]).jacobian
                JT = J.T
                blocks[t] += JT.dot(J)
                grad[t] += JT.dot(R_slices[t])
        # inequality rows: gathered over all slices, then added in a few vectorized operations
        row_t: list[npt.NDArray[np.intp]] = []
        row_J: list[FloatArray] = []
        row_w: list[FloatArray] = []
        row_r: list[FloatArray] = []
        cand_t: list[npt.NDArray[np.intp]] = []
        cand_J: list[FloatArray] = []
        cand_r: list[FloatArray] = []
        cand_id: list[tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.intp]]] = []
        half = 0.5 / penalty
        for n, (term, R) in enumerate(zip(self._ineq_terms, ev.ineq_rows)):
            d = term.dim
            active = R > 0.0
            lower, upper = active[:, :d], active[:, d:]
            needed = lower | upper  # feature rows whose Jacobian is needed, (slices, d)
            cand = None
            if watch is not None and watch[n].any():
                cand = watch[n] & ~active
                needed |= cand[:, :d] | cand[:, d:]
            if not needed.any():
                continue
            used = np.flatnonzero(needed.any(axis=1))
            feature = term.feature
            if term.row_jacobian:
                Jy = np.vstack(
                    [
                        feature.jacobian(states[term.slices[i]], rows=needed[i])  # type: ignore[call-arg]
                        for i in used.tolist()
                    ]
                )
            else:
                Jy = np.vstack(
                    [feature.jacobian(states[term.slices[i]])[needed[i]] for i in used.tolist()]
                )
            ii, kk = np.nonzero(needed[used])  # row-major: the order of Jy's rows
            I = used[ii]
            t_rows = term.slice_array[I]
            # d(lower row)/dq = -sqrt(rho) J, d(upper row)/dq = +sqrt(rho) J
            w = penalty * (lower[I, kk].astype(float) + upper[I, kk])
            on = w > 0.0
            if on.any():
                row_t.append(t_rows[on])
                row_J.append(Jy[on])
                row_w.append(w[on])
                row_r.append(sqrt_rho * (R[I[on], d + kk[on]] - R[I[on], kk[on]]))
            if cand is not None:
                shifted = sqrt_rho * (ev.ineqs[n] + half * multipliers.inequality[n])
                for offset, sign in ((0, -sqrt_rho), (d, sqrt_rho)):
                    pick = cand[I, offset + kk]
                    if pick.any():
                        cand_t.append(t_rows[pick])
                        cand_J.append(sign * Jy[pick])
                        cand_r.append(shifted[I[pick], offset + kk[pick]])
                        cand_id.append((np.full(int(pick.sum()), n), I[pick], offset + kk[pick]))
        if row_t:
            t_all = np.concatenate(row_t)
            J_all = np.vstack(row_J)
            WJ = np.concatenate(row_w)[:, None] * J_all
            _add_rows_to_blocks(blocks, t_all, WJ, J_all)
            np.add.at(grad, t_all, np.concatenate(row_r)[:, None] * J_all)
        m = self._n_limit_rows // 2
        if m:
            R = ev.limit_rows
            active = R > 0.0
            lv = self._limit_v
            blocks[:, lv, lv] += penalty * (active[:, :m].astype(float) + active[:, m:])
            grad[:, lv] += sqrt_rho * (R[:, m:] - R[:, :m])
        H = SymmetricBlockBanded(T, nv, self.order)
        H.add_scalar_band_kron(self._control_band)
        H.add_diagonal_blocks(blocks)
        for k, Rc in ev.control.items():
            c = FINITE_DIFFERENCE_COEFFICIENTS[k]
            scale = self._scales[k]
            for j, cj in enumerate(c):
                # d Psi_t / d q_(t-j) = scale c_j I; q_s with s = t - j, t = s + j <= T
                grad[: T - j] += (scale * cj) * Rc[j:]
        if not cand_t:
            return H, grad.ravel(), _NO_CANDIDATES
        candidates = _CandidateRows(
            np.concatenate(cand_t),
            np.vstack(cand_J),
            np.concatenate(cand_r),
            np.concatenate([c[0] for c in cand_id]),
            np.concatenate([c[1] for c in cand_id]),
            np.concatenate([c[2] for c in cand_id]),
        )
        return H, grad.ravel(), candidates

    @staticmethod
    def _objective(ev: _Evaluation) -> float:
        """The augmented Lagrangian ``L = |r|^2``."""
        total = PathProblem._cost(ev)
        for R in ev.eq_rows:
            total += float(np.vdot(R, R))
        for R in ev.ineq_rows:
            total += float(np.vdot(R, R))
        return total + float(np.vdot(ev.limit_rows, ev.limit_rows))

    @staticmethod
    def _cost(ev: _Evaluation) -> float:
        """``f``: control and task costs only."""
        total = 0.0
        for R in ev.control.values():
            total += float(np.vdot(R, R))
        for E in ev.costs:
            total += float(np.vdot(E, E))
        return total

    @staticmethod
    def _max_violation(ev: _Evaluation) -> float:
        """``max(max |h|, max g, 0)`` over the whole path."""
        out = float(np.max(ev.limits, initial=0.0))
        for Hv in ev.eqs:
            out = max(out, float(np.max(np.abs(Hv), initial=0.0)))
        for G in ev.ineqs:
            out = max(out, float(np.max(G, initial=0.0)))
        return out

    def _violations(self, ev: _Evaluation) -> dict[str, float]:
        out: dict[str, float] = {}
        for term, Hv in zip(self._eq_terms, ev.eqs):
            if term.slices:
                x = float(np.max(np.abs(Hv), initial=0.0))
                out[term.name] = max(out.get(term.name, 0.0), x)
        for term, G in zip(self._ineq_terms, ev.ineqs):
            if term.slices:
                x = float(np.max(G, initial=0.0))
                out[term.name] = max(out.get(term.name, 0.0), x)
        if self._n_limit_rows:
            x = float(np.max(ev.limits, initial=0.0))
            out["joint limits"] = max(out.get("joint limits", 0.0), x)
        return out

    # ------------------------------------------------------------------ per-slice layout
    def _slice_sizes(self) -> list[tuple[int, int, int, int]]:
        """Per slice: first row of the equalities, inequalities, limits; number of rows."""
        n_lim = self._n_limit_rows
        return [
            (
                s.n_cost,
                s.n_cost + s.n_eq,
                s.n_cost + s.n_eq + s.n_in,
                s.n_cost + s.n_eq + s.n_in + n_lim,
            )
            for s in self._slices
        ]

    def _slice_rows(self, ev: _Evaluation) -> list[FloatArray]:
        """The residual rows of each slice (task costs, equalities, inequalities, limits)."""
        sizes = self._slice_sizes()
        rows = [np.zeros(n) for *_, n in sizes]
        for term, E in zip(self._cost_terms, ev.costs):
            for i, (t, o) in enumerate(zip(term.slices, term.offsets)):
                rows[t][o : o + term.dim] = E[i]
        for term, R in zip(self._eq_terms, ev.eq_rows):
            for i, (t, o) in enumerate(zip(term.slices, term.offsets)):
                b = sizes[t][0] + o
                rows[t][b : b + term.dim] = R[i]
        for term, R in zip(self._ineq_terms, ev.ineq_rows):
            for i, (t, o) in enumerate(zip(term.slices, term.offsets)):
                b = sizes[t][1] + o
                rows[t][b : b + 2 * term.dim] = R[i]
        for t, (_, _, b, _) in enumerate(sizes):
            rows[t][b:] = ev.limit_rows[t]
        return rows

    def _slice_jacobians(self, ev: _Evaluation, penalty: float) -> list[FloatArray]:
        """Jacobian (rows x nv) of :meth:`_slice_rows` per slice; inactive rows are 0.

        Built independently of :meth:`_assemble` (full feature Jacobians, then masked): the
        two must agree.
        """
        sizes = self._slice_sizes()
        jac = [np.zeros((n, self.nv)) for *_, n in sizes]
        states = ev.states
        sqrt_rho = math.sqrt(penalty)
        for term in self._cost_terms:
            task = _task(term)
            w = np.reshape(task.sqrt_weight, (-1, 1))
            for t, o in zip(term.slices, term.offsets):
                Jr = term.feature.residual_jacobian(states[t], task.target)
                jac[t][o : o + term.dim] = w * Jr
        for term in self._eq_terms:
            task = _task(term)
            w = sqrt_rho * np.reshape(task.sqrt_weight, (-1, 1))
            for t, o in zip(term.slices, term.offsets):
                b = sizes[t][0] + o
                Jr = term.feature.residual_jacobian(states[t], task.target)
                jac[t][b : b + term.dim] = w * Jr
        for term, R in zip(self._ineq_terms, ev.ineq_rows):
            d = term.dim
            for i, (t, o) in enumerate(zip(term.slices, term.offsets)):
                b = sizes[t][1] + o
                Jy = term.feature.jacobian(states[t])
                act = R[i] > 0.0
                jac[t][b : b + d] = (-sqrt_rho * act[:d, None]) * Jy
                jac[t][b + d : b + 2 * d] = (sqrt_rho * act[d:, None]) * Jy
        for t, (_, _, b, _) in enumerate(sizes):
            act = ev.limit_rows[t] > 0.0
            jac[t][b:] = (sqrt_rho * act[:, None]) * self._limit_jacobian
        return jac

    # ------------------------------------------------------------------ public inspection
    @_locked
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
        mult = self._term_multipliers(multipliers)
        ev = self._evaluate(p, self._states)
        self._set_rows(ev, rho, mult)
        return np.concatenate([R.ravel() for R in ev.control.values()] + self._slice_rows(ev))

    @_locked
    def residual_jacobian(
        self, path: Any, *, penalty: float = 1.0, multipliers: PathMultipliers | None = None
    ) -> scipy.sparse.csr_matrix:
        """Sparse Jacobian of :meth:`residual` with respect to ``q_1..q_T`` (T nv columns)."""
        import scipy.sparse

        p = self.check_path(path)
        rho = check_positive(penalty, "penalty")
        mult = self._term_multipliers(multipliers)
        ev = self._evaluate(p, self._states)
        self._set_rows(ev, rho, mult)
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
        jacobians = [scipy.sparse.csr_matrix(J) for J in self._slice_jacobians(ev, rho)]
        blocks.append(scipy.sparse.block_diag(jacobians, format="csr"))
        return scipy.sparse.vstack(blocks, format="csr")

    @_locked
    def normal_equations(
        self, path: Any, *, penalty: float = 1.0, multipliers: PathMultipliers | None = None
    ) -> tuple[SymmetricBlockBanded, FloatArray]:
        """The banded pseudo-Hessian ``J^T J`` and the gradient half ``J^T r`` at ``path``."""
        p = self.check_path(path)
        rho = check_positive(penalty, "penalty")
        mult = self._term_multipliers(multipliers)
        ev = self._evaluate(p, self._states)
        self._set_rows(ev, rho, mult)
        H, g, _ = self._assemble(ev, rho, mult)
        return H, g

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


def _add_rows_to_blocks(
    blocks: FloatArray, slices: npt.NDArray[np.intp], A: FloatArray, B: FloatArray
) -> None:
    """``blocks[slices[k]] += outer(A[k], B[k])`` summed over rows k (any order of slices)."""
    order = np.argsort(slices, kind="stable")
    t = slices[order]
    outer = A[order, :, None] * B[order, None, :]
    start = np.flatnonzero(np.concatenate([[True], t[1:] != t[:-1]]))
    blocks[t[start]] += np.add.reduceat(outer, start, axis=0)


def _task(term: _Term) -> Task:
    if term.task is None:  # pragma: no cover - set for every cost and equality term
        raise RuntimeError("term without task")
    return term.task


def _weighted_residuals(term: _Term, states: list[State]) -> FloatArray:
    """``sqrt(rho) (phi(q_t) - y*)`` of a task term at its slices, shape (slices, dim)."""
    task = _task(term)
    residual, target = term.feature.residual, task.target
    E = np.array([residual(states[t], target) for t in term.slices], dtype=float)
    E = E.reshape(len(term.slices), term.dim)
    E *= task.sqrt_weight
    return E


def _bounds(term: _Term) -> FeatureBounds:
    if term.bounds is None:  # pragma: no cover - set for every inequality term
        raise RuntimeError("term without bounds")
    return term.bounds


def _accepts_rows(feature: Feature) -> bool:
    """Whether ``feature.jacobian(state, rows=...)`` computes only the selected rows."""
    try:
        params = inspect.signature(feature.jacobian).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False
    return "rows" in params


def _require_target(task: Task) -> None:
    if task.target is None:
        raise InvalidInputError(
            f"task '{task.name}' has no target: call task.set_target(...) before building the "
            "path problem"
        )


# ---------------------------------------------------------------------- solver
def _repair(
    problem: PathProblem,
    path: FloatArray,
    opts: PathOptimizationOptions,
    slices: Iterable[int] | None = None,
) -> int:
    """Push slices violating an inequality out along its gradient (min-norm Gauss-Newton).

    Args:
        problem: the problem.
        path: the path, modified in place.
        opts: settings (``repair_iterations``, ``max_step``).
        slices: the slices ``t`` (1..T) to check; default all.

    Returns:
        The number of slices moved.
    """
    if not problem.inequalities:
        return 0
    repaired = 0
    robot = problem.robot
    lo, hi = robot.lower_limits, robot.upper_limits
    for t in range(1, problem.horizon + 1) if slices is None else slices:
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


_WATCH_IDLE_ITERATIONS = 0
"""Accepted iterations a watched inequality row may stay out of the step's active set before
it is dropped from the model (0: dropped at the first accepted step that did not need it;
keeping rows longer costs their Jacobians at every assembly and did not save iterations)."""


def _age_watch(
    watch: list[npt.NDArray[np.bool_]],
    idle: list[npt.NDArray[np.intp]],
    candidates: _CandidateRows,
    used: npt.NDArray[np.bool_],
    limit: int,
) -> None:
    """Count accepted iterations since each candidate row was last predicted active.

    ``used``: the row's linearization is positive at the step. Rows idle for more than
    ``limit`` iterations leave ``watch``.
    """
    for n, (w, age) in enumerate(zip(watch, idle)):
        mine = candidates.term == n
        if not mine.any():
            continue
        i, k = candidates.index[mine], candidates.row[mine]
        age[i, k] = np.where(used[mine], 0, age[i, k] + 1)
        w[i[age[i, k] > limit], k[age[i, k] > limit]] = False


def _damped_step(
    H: SymmetricBlockBanded,
    grad: FloatArray,
    mu: float,
    candidates: _CandidateRows,
    nv: int,
    passes: int = 6,
) -> FloatArray:
    """Levenberg-Marquardt step: the minimizer of the damped model with hinge rows.

    The model is ``m(dx) = 2 g.dx + dx.(J^T J + mu I).dx + sum_c [r_c + j_c dx]_+^2`` with
    ``g = J^T r``; without candidate rows (or none of them positive at the plain step) the
    step solves ``(J^T J + mu I) dx = -g``. Otherwise ``m`` (convex, piecewise quadratic) is
    minimized by a finite Newton iteration: solve with the candidate rows positive at the
    current step added as quadratics, then an exact line search along the change (the
    model's derivative is piecewise linear along a line); at most ``passes`` solves. Every
    iterate lowers ``m``, and the first is the better of ``0`` and the plain step, so
    ``m(dx) <= 0``.
    """
    damped = H.copy()
    damped.add_diagonal(mu)
    x = damped.solve(-grad)
    if not candidates.size:
        return x
    J, r = candidates.jacobian, candidates.residual
    z = candidates.linearized(x.reshape(-1, nv))
    if not np.any(z > 0.0):
        return x
    # start from the better of the plain step and no step (m(0) = 0)
    Hx = damped.matvec(x)
    if (
        2.0 * float(grad.dot(x)) + float(x.dot(Hx)) + float(np.sum(np.square(np.maximum(z, 0.0))))
        > 0.0
    ):
        x = np.zeros_like(x)
        Hx = np.zeros_like(x)
        z = r.copy()
    active: npt.NDArray[np.bool_] | None = None
    for _ in range(passes - 1):
        now = z > 0.0
        if active is not None and np.array_equal(now, active):
            break  # x minimizes the quadratic of this active set, which holds at x
        active = now
        A = damped.copy()
        rhs = -grad.reshape(-1, nv)
        if active.any():
            Ja, ta = J[active], candidates.slices[active]
            blocks = np.zeros((H.blocks, nv, nv))
            _add_rows_to_blocks(blocks, ta, Ja, Ja)
            A.add_diagonal_blocks(blocks)
            np.subtract.at(rhs, ta, r[active, None] * Ja)
        d = A.solve(rhs.ravel()) - x
        # exact line search: phi'(a) / 2 = b + a c + sum_k [z_k + a s_k]_+ s_k
        Hd = damped.matvec(d)
        c = float(d.dot(Hd))
        b = float(d.dot(grad + Hx))
        s = candidates.linearized(d.reshape(-1, nv)) - r
        slope0 = b + float(np.maximum(z, 0.0).dot(s))
        if slope0 >= 0.0 or c <= 0.0:
            break  # no descent along d
        with np.errstate(divide="ignore", invalid="ignore"):
            breaks = -z / s
        breaks = np.sort(breaks[(breaks > 0.0) & (breaks < 1.0)])
        alphas = np.append(breaks, 1.0)
        slopes = b + alphas * c + (np.maximum(z + alphas[:, None] * s, 0.0) * s).sum(axis=1)
        up = np.flatnonzero(slopes >= 0.0)
        if not up.size:
            alpha = 1.0
        else:
            i = int(up[0])
            lo, lo_slope = (0.0, slope0) if i == 0 else (float(alphas[i - 1]), float(slopes[i - 1]))
            hi, hi_slope = float(alphas[i]), float(slopes[i])
            alpha = lo + (hi - lo) * (-lo_slope) / (hi_slope - lo_slope)
        x = x + alpha * d
        Hx = Hx + alpha * Hd
        z = z + alpha * s
        if alpha < 1.0:
            active = None  # not at the active set's minimizer yet: recompute the set
    return x


def _terms(items: Any, kind: type, name: str) -> list[Any]:
    """A list of ``kind`` terms (an int was a bare TypeError, a Task a bare AttributeError)."""
    if isinstance(items, (str, bytes)) or not hasattr(items, "__iter__"):
        raise InvalidInputError(
            f"{name} must be a list of {kind.__name__}, got {type(items).__name__}"
        )
    out = list(items)
    bad = sorted({type(x).__name__ for x in out if not isinstance(x, kind)})
    if bad:
        raise InvalidInputError(
            f"{name} must hold {kind.__name__} objects, got {', '.join(bad)} (wrap a Task as "
            f"{kind.__name__}(task, times=...))"
        )
    return out


def _check_options(opts: PathOptimizationOptions) -> None:
    """Iteration counts are integers (a float cap such as ``math.inf`` would never stop).

    Edges that solved another problem than asked are refused: ``constraint_tolerance`` below
    :data:`MIN_CONSTRAINT_TOLERANCE` (0 reported INFEASIBLE at a violation of 3e-16),
    ``initial_damping`` 0 (the damping grows by factors from it: a rejected step was retried
    undamped until ``max_iterations``), ``max_penalty < initial_penalty`` (the penalty
    started above its maximum) and ``violation_decrease > 1`` (no decrease).
    """
    if not isinstance(opts, PathOptimizationOptions):
        raise InvalidInputError(
            f"options must be a PathOptimizationOptions, got {type(opts).__name__}"
        )
    check_count(opts.max_iterations, "max_iterations")
    check_count(opts.max_outer_iterations, "max_outer_iterations")
    check_count(opts.repair_iterations, "repair_iterations")
    for name in ("constraint_tolerance", "step_tolerance", "cost_tolerance"):
        check_positive(getattr(opts, name), name, strict=False)
    for name in ("initial_penalty", "max_penalty", "max_step", "violation_decrease"):
        check_positive(getattr(opts, name), name)
    check_positive(opts.initial_damping, "initial_damping")
    if opts.constraint_tolerance < MIN_CONSTRAINT_TOLERANCE:
        raise InvalidInputError(
            f"constraint_tolerance must be >= {MIN_CONSTRAINT_TOLERANCE:g}, got "
            f"{opts.constraint_tolerance!r}: violations below it are the rounding of the "
            "features (an equality reached 3e-16, not 0), so the solver raised the penalty to "
            "its maximum and reported INFEASIBLE"
        )
    if opts.max_penalty < opts.initial_penalty:
        raise InvalidInputError(
            f"max_penalty ({float(opts.max_penalty)!r}) must be >= initial_penalty "
            f"({float(opts.initial_penalty)!r}): the penalty starts at initial_penalty and "
            "grows up to max_penalty (equal values: a fixed penalty)"
        )
    if opts.violation_decrease > 1.0:
        raise InvalidInputError(
            f"violation_decrease must be in (0, 1], got {opts.violation_decrease!r}: the "
            "penalty grows unless the violation shrank to this fraction of the previous one"
        )
    if not opts.penalty_growth > 1.0 or not math.isfinite(opts.penalty_growth):
        raise InvalidInputError(
            f"penalty_growth must be finite and > 1, got {opts.penalty_growth!r}"
        )


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

    Inactive inequality rows are invisible to the Gauss-Newton model, so a step may cross
    them (e.g. move a link through an obstacle) and be rejected. The rows found active at a
    rejected trial point are then kept in the model as hinges ``[r + j dx]_+^2`` (see
    :func:`_damped_step`) and the step is recomputed with the same damping, instead of
    only raising ``mu``; such a row leaves the model at the first accepted step that did
    not need it.

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
        InvalidInputError: a non-integer or negative iteration count, a NaN or negative
            tolerance, penalty or damping, or an edge listed in
            :class:`PathOptimizationOptions` (``constraint_tolerance < 1e-12``,
            ``initial_damping = 0``, ``max_penalty < initial_penalty``,
            ``violation_decrease > 1``).
        SolverError: the banded factorization failed even with large damping.
    """
    if not isinstance(problem, PathProblem):
        raise InvalidInputError(f"problem must be a PathProblem, got {type(problem).__name__}")
    with problem._lock:  # one problem, one workspace: concurrent calls are serialized
        return _optimize_path(problem, initial_path, options)


def _optimize_path(
    problem: PathProblem, initial_path: Any, options: PathOptimizationOptions | None
) -> PathOptimizationResult:
    opts = options if options is not None else PathOptimizationOptions()
    _check_options(opts)
    t_start = time.perf_counter()
    path = problem.initial_path(initial_path)
    T, nv = problem.horizon, problem.nv
    states = problem._states
    trial_states = problem._trial_states
    mult = problem._term_multipliers(None)
    rho = opts.initial_penalty
    eval_time = 0.0
    solve_time = 0.0

    t0 = time.perf_counter()
    ev = problem._evaluate(path, states)
    repaired = 0
    if opts.repair:
        # only the slices that violate an inequality (the evaluation tells which)
        violating = sorted(
            {
                term.slices[i] + 1
                for term, G in zip(problem._ineq_terms, ev.ineqs)
                for i in np.flatnonzero((G > 0.0).any(axis=1))
            }
        )
        if violating:
            repaired = _repair(problem, path, opts, violating)
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
    candidates = _NO_CANDIDATES
    rejected_step: FloatArray | None = None
    # inequality rows found active at a rejected trial point: modeled as hinges from then on
    watch = [np.zeros((len(term.slices), 2 * term.dim), dtype=bool) for term in problem._ineq_terms]
    # iterations since a watched row was last predicted active (rows unused for long are
    # dropped: their Jacobians cost time at every assembly)
    idle = [np.zeros(w.shape, dtype=np.intp) for w in watch]
    while iterations < opts.max_iterations:
        if inner_done:
            inner_done = False
            if violation <= opts.constraint_tolerance:
                status = PathOptimizationStatus.CONVERGED
                break
            if outer >= opts.max_outer_iterations:
                break
            outer += 1
            if logger.isEnabledFor(logging.DEBUG):
                logger.debug("outer %d: violations %s", outer, problem._violations(ev))
            problem._update_multipliers(ev, rho, mult)
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
            H, grad, candidates = problem._assemble(ev, rho, mult, watch)
            eval_time += time.perf_counter() - t0
            if mu < 0:
                mu = opts.initial_damping * float(np.max(H.ab[0]))
        iterations += 1
        t0 = time.perf_counter()
        dx = _damped_step(H, grad, mu, candidates, nv)
        solve_time += time.perf_counter() - t0
        largest = float(np.max(np.abs(dx))) if dx.size else 0.0
        if largest > opts.max_step:
            dx *= opts.max_step / largest
            largest = opts.max_step
        if rejected_step is not None and np.array_equal(dx, rejected_step):
            # the rows learned at the rejection do not change the step: damp more instead
            # of evaluating the same trial again
            rejected_step = None
            mu *= nu
            nu *= 2.0
            continue
        rejected_step = None
        # predicted decrease of the model |r + J dx|^2 + sum [r_c + j_c dx]_+^2
        z = candidates.linearized(dx.reshape(T, nv))
        hinge = float(np.sum(np.square(np.maximum(z, 0.0))))
        predicted = -(2.0 * float(grad.dot(dx)) + float(dx.dot(H.matvec(dx)))) - hinge
        trial = path.copy()
        trial[1:] += dx.reshape(T, nv)
        t0 = time.perf_counter()
        trial_ev = problem._evaluate(trial, trial_states)
        problem._set_rows(trial_ev, rho, mult)
        eval_time += time.perf_counter() - t0
        trial_objective = problem._objective(trial_ev)
        decrease = objective - trial_objective
        logger.debug(
            "LM %d (outer %d): rho %.3g mu %.3g |dx| %.3g L %.6g -> %.6g predicted %.3g",
            iterations,
            outer,
            rho,
            mu,
            largest,
            objective,
            trial_objective,
            predicted,
        )
        if decrease > 0 and predicted > 0:
            ratio = decrease / predicted
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
            nu = 2.0
            path, ev, objective = trial, trial_ev, trial_objective
            states, trial_states = trial_states, states
            if candidates.size:
                # (only at accepted steps: rows learned at a rejection stay until one is)
                _age_watch(watch, idle, candidates, z > 0.0, _WATCH_IDLE_ITERATIONS)
            H = None
            violation = problem._max_violation(ev)
            cost_history.append(problem._cost(ev))
            violation_history.append(violation)
            if largest < opts.step_tolerance or decrease < opts.cost_tolerance * objective:
                inner_done = True
        else:
            # inequality rows the model missed (inactive here, active at the trial): model
            # them from now on and retry with the same damping; otherwise damp more
            learned = False
            for w, age, row_trial, row in zip(watch, idle, trial_ev.ineq_rows, ev.ineq_rows):
                new = (row_trial > 0.0) & (row <= 0.0) & ~w
                if new.any():
                    w |= new
                    age[new] = 0
                    learned = True
            if learned:
                H = None
                rejected_step = dx
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
