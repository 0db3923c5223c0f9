"""Position-level inverse kinematics: Gauss-Newton to convergence (slides 2:29, 2:34).

Iterates the weighted differential step (all gains 1) from ``q``: ``q <- q (+) alpha dq`` with
a backtracking line search on ``f(q) = sum_i rho_i |e_i(q)|^2`` and Levenberg-Marquardt
damping adapted to progress, inside the joint limits. Optional random restarts (seeded).

Thread safety: :func:`solve_ik` builds its own states and solvers per call and only reads the
tasks, so calls may run from several threads (with tasks, constraints and robot not changed
meanwhile); :class:`SolveIKOptions` and :class:`SolveIKStatus` are immutable; a
:class:`SolveIKResult` is plain result data, not locked.
"""

from __future__ import annotations

import copy
import enum
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_count, check_positive
from taskspace.constraints.constraint import Constraint
from taskspace.constraints.joint_limits import JointPositionLimits
from taskspace.errors import InvalidInputError
from taskspace.features.frame_pose import FramePose
from taskspace.ik.differential_ik import DifferentialIK, DifferentialIKOptions
from taskspace.model.robot import Robot
from taskspace.qp.solver import QPSolverOptions
from taskspace.tasks import Task


class SolveIKStatus(enum.Enum):
    """Outcome of :func:`solve_ik`."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    STALLED = "stalled"


@dataclass(frozen=True, kw_only=True)
class SolveIKOptions:
    """Settings of :func:`solve_ik`.

    Attributes:
        max_iterations: Gauss-Newton iterations per attempt.
        stall_window: an attempt stops (and the next restart begins) when the cost fell by
            less than 1 % over this many iterations (stuck against joint limits).
        position_tolerance: convergence threshold on position errors [m] (and on the norm of
            non-pose task errors).
        rotation_tolerance: convergence threshold on rotation errors [rad].
        initial_damping: initial Levenberg-Marquardt damping ``mu`` (at least 1e-12, the
            floor the damping keeps after every step, so a redundant robot's first step is
            defined with 0 too) [1/rad^2].
        max_step: largest joint step per iteration [rad or m] (trust region).
        restarts: random restarts after a failed first attempt.
        backend: QP backend.
    """

    max_iterations: int = 200
    position_tolerance: float = 1e-6
    rotation_tolerance: float = 1e-5
    initial_damping: float = 1e-6
    max_step: float = 0.5
    restarts: int = 0
    stall_window: int = 15
    backend: str = "proxsuite"


@dataclass
class SolveIKResult:
    """Result of :func:`solve_ik`.

    Attributes:
        success: every task converged within tolerance (in its directions of nonzero
            weight).
        status: see :class:`SolveIKStatus`.
        q: final configuration (the best one found).
        iterations: total Gauss-Newton iterations (all attempts).
        attempts: 1 + restarts used.
        errors: per task, the final residual norm.
        cost_history: ``f(q)`` after each accepted iteration of the returned attempt.
        solve_time: wall time [s].
    """

    success: bool
    status: SolveIKStatus
    q: FloatArray
    iterations: int
    attempts: int
    errors: dict[str, float]
    cost_history: list[float] = field(default_factory=list)
    solve_time: float = 0.0


class _StepBox(Constraint):
    hard_bounds = True

    def __init__(self, robot: Robot, max_step: float) -> None:
        super().__init__(robot, "step size")
        self.max_step = max_step

    def bounds(self, state, dt):  # type: ignore[no-untyped-def]
        return np.full(self.robot.nv, -self.max_step), np.full(self.robot.nv, self.max_step)


def _converged(tasks: Sequence[Task], errors: list[FloatArray], opts: SolveIKOptions) -> bool:
    for task, e in zip(tasks, errors):
        # directions of weight 0 are not part of the objective: they need not converge
        e = np.where(np.broadcast_to(np.asarray(task.sqrt_weight) > 0.0, e.shape), e, 0.0)
        if isinstance(task.feature, FramePose):
            if np.linalg.norm(e[:3]) > opts.position_tolerance:
                return False
            if np.linalg.norm(e[3:]) > opts.rotation_tolerance:
                return False
        elif np.linalg.norm(e) > opts.position_tolerance:
            return False
    return True


def solve_ik(
    robot: Robot,
    tasks: Sequence[Task],
    q0: object = None,
    *,
    constraints: Sequence[Constraint] | None = None,
    options: SolveIKOptions | None = None,
    rng: np.random.Generator | None = None,
) -> SolveIKResult:
    """Solve ``min_q sum_i rho_i |phi_i(q) - y_i*|^2`` within the joint limits.

    Args:
        robot: the robot.
        tasks: tasks with targets (gains are ignored: full Gauss-Newton steps; the tasks
            are not changed). Directions of weight 0 are not part of the objective and need
            not reach the tolerances (``weight=[1, 1, 1, 0, 0, 0]`` on a frame pose asks for
            its position only); ``errors`` still reports the whole residual.
        q0: initial configuration (default: the robot's default posture); with the default
            constraints, joints outside their position limits are first clipped into them.
        constraints: constraints (default: joint position limits).
        options: settings.
        rng: random generator for restarts (required when ``options.restarts > 0``).

    Returns:
        The result; ``success`` tells whether the tolerances were reached.
    """
    if isinstance(tasks, Task) or not isinstance(tasks, Sequence) or not tasks:
        raise InvalidInputError(
            f"solve_ik needs a non-empty list of tasks, e.g. [task], got {type(tasks).__name__}"
        )
    for j, t in enumerate(tasks):
        if not isinstance(t, Task):
            raise InvalidInputError(f"tasks[{j}] must be a Task, got {type(t).__name__}")
    opts = options or SolveIKOptions()
    check_count(opts.max_iterations, "max_iterations", minimum=1)
    check_count(opts.restarts, "restarts")
    check_count(opts.stall_window, "stall_window", minimum=1)
    check_positive(opts.initial_damping, "initial_damping", strict=False)
    check_positive(opts.max_step, "max_step")
    if opts.restarts > 0 and rng is None:
        raise InvalidInputError("solve_ik with restarts needs rng=np.random.default_rng(seed)")
    t0 = time.perf_counter()
    q_start = robot.check_configuration(robot.q_default if q0 is None else q0, "q0")
    if constraints is None:
        # The default constraint keeps q + dq inside the limits; from a start outside them it
        # cannot, and the result was 'converged' outside the limits (q0 wrist_3 = 10 on ur5
        # ended at 7 > 2 pi). An initial guess outside the limits is projected into them.
        idx = robot.limited_joints_q
        q_start = q_start.copy()
        q_start[idx] = np.clip(q_start[idx], robot.lower_limits[idx], robot.upper_limits[idx])
    cons: list[Constraint] = (
        [JointPositionLimits(robot)] if constraints is None else list(constraints)
    )
    cons.append(_StepBox(robot, opts.max_step))
    # full Gauss-Newton steps: the solver steps with copies of the tasks of gain 1 (the
    # caller's tasks are only read: another thread may step with them meanwhile)
    tasks = [_full_step_task(t) for t in tasks]
    total_iterations = 0
    attempts = 0
    best: SolveIKResult | None = None
    for attempt in range(1 + opts.restarts):
        if attempt > 0:
            if rng is None:  # pragma: no cover - checked above
                raise InvalidInputError("restarts need an rng")
            q_start = robot.random_configuration(rng)
        result = _gauss_newton(robot, tasks, q_start, cons, opts)
        total_iterations += result.iterations
        attempts = attempt + 1
        # the best attempt in the objective's sense: least final f(q) (the unweighted sum of
        # error norms mixed metres and radians and counted directions of weight 0)
        if best is None or result.cost_history[-1] < best.cost_history[-1]:
            best = result
        if result.success:
            best = result
            break
    if best is None:  # pragma: no cover - the loop runs at least once
        raise RuntimeError("solve_ik ran no attempt")
    best.iterations = total_iterations
    best.attempts = attempts
    best.solve_time = time.perf_counter() - t0
    return best


def _full_step_task(task: Task) -> Task:
    """A shallow copy of ``task`` (same feature, target and weight) with gain 1."""
    full = copy.copy(task)
    full.gain = 1.0
    return full


def _gauss_newton(
    robot: Robot,
    tasks: Sequence[Task],
    q: FloatArray,
    constraints: list[Constraint],
    opts: SolveIKOptions,
) -> SolveIKResult:
    mu = max(opts.initial_damping, 1e-12)  # as after every step: H stays positive definite
    state = robot.state(q)
    trial = robot.state(q)

    def cost_and_errors(s: object) -> tuple[float, list[FloatArray]]:
        errs = [t.error(s) for t in tasks]  # type: ignore[arg-type]
        c = sum(float(np.sum((np.asarray(t.sqrt_weight) * e) ** 2)) for t, e in zip(tasks, errs))
        return c, errs

    cost, errors = cost_and_errors(state)
    history = [cost]
    status = SolveIKStatus.MAX_ITERATIONS
    iterations = 0
    solver_options = QPSolverOptions(backend=opts.backend)
    for iterations in range(1, opts.max_iterations + 1):
        if _converged(tasks, errors, opts):
            status = SolveIKStatus.CONVERGED
            iterations -= 1
            break
        ik = DifferentialIK(
            robot,
            tasks,
            constraints,
            options=DifferentialIKOptions(damping=mu, solver=solver_options),
        )
        step = ik.solve(state, 1.0)
        dq = step.dq
        alpha = 1.0
        accepted = False
        while alpha > 1e-4:
            q_new = pin.integrate(robot._model, state.q, alpha * dq)
            trial.update(q_new, validate=False)
            new_cost, new_errors = cost_and_errors(trial)
            if new_cost < cost * (1 - 1e-4 * alpha) or new_cost < 1e-30:
                accepted = True
                break
            alpha *= 0.5
        if accepted:
            state.update(trial.q, validate=False)
            cost, errors = new_cost, new_errors
            history.append(cost)
            mu = max(mu / 3.0, 1e-12)
            w = opts.stall_window
            if len(history) > w and history[-1] > 0.99 * history[-1 - w]:
                if not _converged(tasks, errors, opts):
                    status = SolveIKStatus.STALLED
                    break
        else:
            mu = max(10.0 * mu, 1e-12)  # a damping of 0 would stay 0
            if mu > 1e6:
                status = SolveIKStatus.STALLED
                break
    else:
        if _converged(tasks, errors, opts):
            status = SolveIKStatus.CONVERGED
    return SolveIKResult(
        status is SolveIKStatus.CONVERGED,
        status,
        np.array(state.q),
        iterations,
        1,
        {t.name: float(np.linalg.norm(e)) for t, e in zip(tasks, errors)},
        history,
    )
