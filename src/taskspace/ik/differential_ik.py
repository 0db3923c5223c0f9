"""Weighted multi-task differential inverse kinematics as one QP (slides 2:25-2:29, 2:39-2:41).

One step solves

``min_dq  sum_i rho_i |J_i dq + gain_i e_i|^2 + mu |dq|^2``
``s.t.    A dq = b`` (hard tasks), ``l <= C dq <= u`` (collision dampers, feature bounds),
``lb <= dq <= ub`` (joint position, velocity and acceleration limits),

the linearization of ``min_q |q - q0|^2_W + sum_i rho_i |phi_i(q) - y_i*|^2`` with
``W = mu I``. ``dq`` is a tangent vector: the next configuration is ``q (+) dq`` and the
velocity ``dq / dt``.

Thread safety: :class:`DifferentialIK` serializes ``solve`` and ``advance`` on a lock (each
thread should still move its own :class:`~taskspace.model.State`); :class:`DifferentialIKOptions`
is immutable and :class:`IKStatus` an enum; an :class:`IKStepResult` is plain data whose lazy
``velocity`` and ``qp`` are computed idempotently on first access, so several threads may read
one result (do not assign its fields while others read it).
"""

from __future__ import annotations

import dataclasses
import enum
import math
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_positive
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError, SolverError
from taskspace.ik._native_stack import (
    GENERAL_ENGINES,
    MAX_ACTIVE_SET_ITERATIONS,
    NativeWeightedStack,
)
from taskspace.ik._native_stack import supported as native_supported
from taskspace.model.robot import Robot
from taskspace.model.state import State
from taskspace.qp.kkt import KKTResiduals, box_kkt_residuals, kkt_residuals
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus
from taskspace.qp.rows import WeightedQPBuilder
from taskspace.qp.solver import QPSolver, QPSolverOptions
from taskspace.tasks import ASSIGNMENTS as _ASSIGNMENTS
from taskspace.tasks import Task

_perf_counter = time.perf_counter
_empty = np.empty
_new = object.__new__
_integrate = pin.integrate
_INF = float("inf")
_NAN = float("nan")
_SOLVED = QPStatus.SOLVED
_UNCONSTRAINED = QPStatus.UNCONSTRAINED
_NO_Z = np.zeros(0)
_NO_Z.flags.writeable = False


FAILED_STEP_BOX_TOLERANCE = 1e-6
"""Largest box violation [rad, m] of a failed QP's last iterate that a FAILED step keeps
(clipped to the box); a larger one is replaced by the box's point nearest zero."""


class IKStatus(enum.Enum):
    """Outcome of a differential IK step."""

    SOLVED = "solved"
    RELAXED = "relaxed"
    FAILED = "failed"


_IK_SOLVED = IKStatus.SOLVED


class IKStepResult:
    """Result of one differential IK step.

    Attributes:
        success: the QP was solved with every hard constraint satisfied.
        status: see :class:`IKStatus`.
        dq: the step (tangent vector, size nv) [rad, m]; when FAILED (no backend solved
            the QP), a step within the hard box (the backend's last iterate clipped to it
            when that was within 1e-6 rad of it, else the box's point nearest zero), not
            necessarily within the inequality rows.
        culprits: constraints at fault when the hard constraints conflict (every one the
            least-violating step violates; ``qp.conflict``: a minimal conflicting subset of
            the QP's blocks).
        build_time, solve_time: wall times [s].

    ``velocity`` (``dq / dt``) and ``qp`` (the QP result) are properties: a solver may give
    ``dt`` and the QP result's fields instead, and they are then made on first access. One
    result is made at every step: the class has ``__slots__`` and does no work beyond
    storing its fields.
    """

    __slots__ = (
        "_declined",
        "_dt",
        "_qp",
        "_velocity",
        "build_time",
        "culprits",
        "dq",
        "solve_time",
        "status",
        "success",
    )
    _declined: str  # why the compiled kernel declined (set only then; see native_declined)

    def __init__(
        self,
        success: bool,
        status: IKStatus,
        dq: FloatArray,
        velocity: FloatArray | None,
        qp: QPResult | tuple[Any, ...],
        culprits: list[str] | None = None,
        build_time: float = 0.0,
        solve_time: float = 0.0,
        *,
        dt: float | None = None,
    ) -> None:
        if velocity is None and dt is None:
            raise InvalidInputError("IKStepResult needs the velocity or the time step dt")
        self.success = success
        self.status = status
        self.dq = dq
        self._velocity = velocity
        self._dt = dt
        self._qp = qp
        self.culprits = [] if culprits is None else culprits
        self.build_time = build_time
        self.solve_time = solve_time

    @property
    def velocity(self) -> FloatArray:
        """The step's velocity ``dq / dt`` [rad/s, m/s]."""
        v = self._velocity
        if v is None:
            dt = self._dt
            assert dt is not None  # __init__ refuses neither velocity nor dt
            v = self._velocity = self.dq / dt
        return v

    @velocity.setter
    def velocity(self, value: FloatArray) -> None:
        self._velocity = value

    @property
    def native_declined(self) -> str:
        """Why the compiled kernel declined this step (the Python path answered).

        ``""`` when the kernel answered or was not tried.
        """
        return getattr(self, "_declined", "")

    @property
    def qp(self) -> QPResult:
        """The QP result (status, backend, iterations, KKT residuals, culprits when relaxed)."""
        qp = self._qp
        if type(qp) is tuple:  # the fields of a QPResult, given by the compiled path
            if len(qp) > 9:  # with the kernel's KKT residuals as a plain tuple (+ multipliers)
                qp = (*qp[:9], KKTResiduals(*qp[9]), *qp[10:])
            qp = self._qp = QPResult(*qp)
        return qp  # type: ignore[return-value]

    @qp.setter
    def qp(self, value: QPResult) -> None:
        self._qp = value

    def __repr__(self) -> str:
        return (
            f"IKStepResult(success={self.success}, status={self.status}, dq={self.dq!r}, "
            f"qp={self.qp!r}, culprits={self.culprits!r}, build_time={self.build_time!r}, "
            f"solve_time={self.solve_time!r})"
        )


def _separate_boxes(p: QPProblem, boxes: list[tuple[str, FloatArray, FloatArray]]) -> QPProblem:
    """``p`` with its merged box replaced by one block of unit rows per box constraint."""
    n = p.n
    eye = np.eye(n)
    C = np.vstack([p.C, *[eye] * len(boxes)])
    l = np.concatenate([p.l, *[lo for _, lo, _ in boxes]])
    u = np.concatenate([p.u, *[hi for _, _, hi in boxes]])
    blocks = list(p.in_blocks)
    for k, (name, _, _) in enumerate(boxes):
        start = p.n_in + k * n
        blocks.append(RowBlock(name, start, start + n))
    return QPProblem(
        p.H, p.g, p.A, p.b, C, l, u, np.full(n, -INF), np.full(n, INF), p.eq_blocks, blocks, []
    )


# what the compiled armed advance fills (NativeWeightedStack.arm_advance): the class, its
# slots' member descriptors and the constants of a solved step
_RESULT_SLOTS = (
    IKStepResult,
    *(
        IKStepResult.__dict__[name]
        for name in (
            "success",
            "status",
            "dq",
            "_velocity",
            "_dt",
            "_qp",
            "culprits",
            "build_time",
            "solve_time",
        )
    ),
    _IK_SOLVED,
    _UNCONSTRAINED,
    _SOLVED,
    "native",
)


@dataclass(frozen=True, kw_only=True)
class DifferentialIKOptions:
    """Settings of :class:`DifferentialIK`.

    Attributes:
        damping: ``mu`` of the regularization ``mu |dq|^2`` (the metric ``W`` of slide 2:26;
            keeps steps bounded near singularities) [1/rad^2].
        solver: QP solver settings (backend, fallbacks, tolerances).
        native: run the compiled kernel (``taskspace/_native``) when it is built and the
            stack is one it serves: every task's feature declares a compiled term
            (:meth:`~taskspace.features.feature.Feature.compiled_term`: frame pose, frame
            origin, frame orientation, center of mass, posture). Boxes (joint position,
            velocity, acceleration limits) and the inequality rows whose constraint declares
            that the kernel evaluates them
            (:meth:`~taskspace.constraints.constraint.Constraint.compiled_constraint`:
            collision velocity dampers, coal distances computed in the kernel) are solved by
            a primal active-set method on the box, then a primal-dual active-set method on
            the rows and the box when the box solution violates a row. Equality tasks and
            the other inequality rows (feature bounds, a user's rows; evaluated in Python)
            are solved with them by the kernel's general step (a dual active-set method
            warm-started with the previous step's active set, or proxsuite: see
            ``native_general_engine``).
            A step with rows carries its KKT residuals and is accepted only within the
            tolerances of ``solver``; other stacks, and any step the kernel declines (its
            reason in ``IKStepResult.native_declined``), take the Python path with
            ``solver``.
        native_residuals: give the compiled kernel's steps their KKT residuals
            (``IKStepResult.qp.kkt``): the QP of the Python path (:meth:`DifferentialIK.build`)
            is built for the same state and checked at the kernel's step, with the bound
            multipliers recovered from stationarity (:func:`~taskspace.qp.kkt.box_kkt_residuals`).
            Off by default: building that QP costs more than the kernel's whole step; when off,
            a kernel step's ``qp.kkt`` is NaN (not computed). Steps of stacks with compiled
            inequality rows always carry the kernel's own residuals (this option is unused).
        native_general_engine: the QP engine of the kernel's general step (stacks with
            equality tasks or rows evaluated in Python): ``"auto"`` (chosen per problem
            class, see :class:`~taskspace.ik._native_stack.NativeWeightedStack`),
            ``"active_set"`` (dual active-set method warm-started with the previous step's
            active set) or ``"proxsuite"`` (proxsuite's dense solver in C++, workspace kept
            and warm-started). Every engine's step is accepted only within the tolerances
            of ``solver``.
    """

    damping: float = 1e-6
    solver: QPSolverOptions = field(default_factory=QPSolverOptions)
    native: bool = True
    native_residuals: bool = False
    native_general_engine: str = "auto"

    def __post_init__(self) -> None:
        """Refuse an unknown general-step engine (the valid names listed)."""
        if self.native_general_engine not in GENERAL_ENGINES:
            raise InvalidInputError(
                f"native_general_engine must be one of {GENERAL_ENGINES}, got "
                f"{self.native_general_engine!r}"
            )


def _require_state(state: object) -> None:
    raise InvalidInputError(
        f"state must be a taskspace State (robot.state(q) or robot.state(q, v)), got "
        f"{type(state).__name__}"
    )


def _flat_list(items: object, kind: type, name: str) -> list:  # type: ignore[type-arg]
    """``items`` as a list whose elements are all ``kind``; else a clear error."""
    what = kind.__name__
    if isinstance(items, (kind, str, bytes)) or not isinstance(items, Iterable):
        hint = f": write [{name[:-1]}]" if isinstance(items, kind) else ""
        raise InvalidInputError(
            f"{name} must be a list of {what} objects, got {type(items).__name__}{hint}"
        )
    items = list(items)
    for i, item in enumerate(items):
        if not isinstance(item, kind):
            hint = (
                "; DifferentialIK takes one flat list (HierarchicalIK takes levels)"
                if isinstance(item, (list, tuple))
                else ""
            )
            raise InvalidInputError(
                f"{name}[{i}] must be a {what}, got {type(item).__name__}{hint}"
            )
    return items


class DifferentialIK:
    """Weighted multi-task differential IK with limits, collisions and hard tasks.

    The proxsuite workspace is kept between steps (updated and warm-started); when the
    unconstrained minimizer already respects every bound no QP iteration is run.

    Thread safety: :meth:`solve`, :meth:`step` and :meth:`build` may be called from several
    threads on one solver: they hold the solver's lock while they use its workspaces (the
    stacked task matrix, the QP workspace, the compiled kernel), so the calls run one at a
    time and each gives the result it would give alone (up to the QP warm start); the armed
    compiled ``advance`` does not take the lock but checks that it is free and then holds the
    GIL until its step is computed (it waits on the lock otherwise). Each
    thread needs its own :class:`~taskspace.model.State`, and the tasks' targets, weights and
    gains must not be changed while another thread steps. For parallel speed, give each
    thread its own solver.

    Args:
        robot: the robot.
        tasks: weighted tasks (their ``priority`` is ignored here).
        constraints: joint limits, collision avoidance, feature bounds...
        equality_tasks: tasks imposed exactly (``J dq = -gain e``) as equality constraints.
        options: settings.
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Sequence[Task],
        constraints: Sequence[Constraint] = (),
        equality_tasks: Sequence[Task] = (),
        options: DifferentialIKOptions | None = None,
    ) -> None:
        if not isinstance(robot, Robot):
            raise InvalidInputError(
                f"robot must be a taskspace Robot (Robot.load(name)), got {type(robot).__name__}"
            )
        self.robot = robot
        self.tasks = _flat_list(tasks, Task, "tasks")
        self.constraints = _flat_list(constraints, Constraint, "constraints")
        self.equality_tasks = _flat_list(equality_tasks, Task, "equality_tasks")
        if options is not None and not isinstance(options, DifferentialIKOptions):
            raise InvalidInputError(
                f"options must be a DifferentialIKOptions, got {type(options).__name__}"
            )
        self._options = options or DifferentialIKOptions()
        check_positive(self.options.damping, "damping", strict=False)
        for item in [*self.tasks, *self.equality_tasks]:
            if item.feature.robot is not robot:
                raise InvalidInputError(f"task '{item.name}' is defined on another robot")
        for c in self.constraints:
            if c.robot is not robot:
                raise InvalidInputError(f"constraint '{c.name}' is defined on another robot")
        if not self.tasks and not self.equality_tasks:
            raise InvalidInputError("DifferentialIK needs at least one task")
        self.solver = QPSolver(self.options.solver)
        self._builder = WeightedQPBuilder(
            self.tasks, self.constraints, self.equality_tasks, robot.nv, self.options.damping
        )
        self._inequality_constraints = self._builder.inequalities.constraints
        self._native: NativeWeightedStack | None = None
        self._native_checked = False
        self._fused = False  # advance() runs the kernel's fused step (set with _native)
        self._nv = robot.nv
        self._damping = self.options.damping  # options are frozen and fixed (read-only)
        self._native_residuals = self.options.native_residuals
        self._lock = threading.Lock()
        self._acquire = self._lock.acquire
        self._release = self._lock.release
        # advance()'s lean path (see _arm): armed after a fused step of a box-only stack for
        # this dt, task assignment count and robot version; NaN: not armed (equals no dt)
        self._lean_dt = _NAN
        self._lean_assignments = -1
        self._lean_version = -1
        self._lean_boxes: tuple[list[Any], list[Any]] | None = None
        self._lean_step: Any = None  # the kernel's armed step (NativeWeightedStack.arm)
        # the whole armed advance in C (NativeWeightedStack.arm_advance): gate, lock check,
        # step, state, result; None when not armed
        self._lean_fast: Any = None

    @property
    def options(self) -> DifferentialIKOptions:
        """The settings (read-only: the QP builder, solver and kernel are made from them)."""
        return self._options

    @options.setter
    def options(self, value: Any) -> None:
        raise InvalidInputError(
            "DifferentialIK.options is read-only (the QP builder, the solver and the compiled "
            "kernel are made from them at construction): make a new DifferentialIK"
        )

    @property
    def native(self) -> bool:
        """Whether steps run on the compiled kernel (see :class:`DifferentialIKOptions`)."""
        if not self._native_checked:
            self._native_checked = True
            if self.options.native and native_supported(
                self.tasks, self._inequality_constraints, self.equality_tasks
            ):
                solver = self.options.solver
                self._native = NativeWeightedStack(
                    self.robot,
                    self.tasks,
                    self.constraints,
                    self._inequality_constraints,
                    (solver.eps_abs, solver.eps_rel),
                    self.equality_tasks,
                    self.options.native_general_engine,
                )
                # advance() in one kernel call; not with native_residuals (they are checked on
                # the QP built at the state before it moves), nor with a kernel built before
                # its advance existed
                self._fused = self._native.advance is not None and not self.options.native_residuals
        return self._native is not None

    def build(self, state: State, dt: float) -> QPProblem:
        """Assemble the QP of one step from ``state`` during ``dt`` [s] (inspectable).

        The arrays of the returned problem are buffers of the solver, refilled by the next
        ``build`` or ``solve`` (copy them to keep a snapshot).
        """
        if not isinstance(state, State):
            _require_state(state)
        with self._lock:
            return self._build(state, dt)

    def _build(self, state: State, dt: float) -> QPProblem:
        """:meth:`build` without the lock (the caller holds it)."""
        return self._builder.build(state, dt)

    def solve(self, state: State, dt: float) -> IKStepResult:
        """One step: build and solve the QP.

        Args:
            state: current state (its velocity is used by acceleration limits).
            dt: time step [s].
        """
        if type(state) is not State and not isinstance(state, State):
            _require_state(state)
        dt = check_positive(dt, "dt")
        self._acquire()  # bound methods: about half the cost of ``with self._lock``
        try:
            if self._native is not None or (not self._native_checked and self.native):
                native = self._solve_native(state, dt)
                if native is not None:
                    return native
                result = self._solve_python(state, dt)
                result._declined = self._native.declined  # type: ignore[union-attr]
                return result
            return self._solve_python(state, dt)
        finally:
            self._release()

    def advance(self, state: State, dt: float) -> IKStepResult:
        """One step that moves ``state``: solve at it, then ``state`` goes to ``q (+) dq``.

        The loop ``state.update(q); result = solve(state, dt); q = q (+) result.dq`` in one
        call: on the compiled kernel the solve, the integration and the kinematics of the
        new configuration (Pinocchio's ``computeJointJacobians`` and frame placements, as
        :meth:`State.update`) run in one compiled call on the state's own data; on the
        Python path (or when the kernel's step is not accepted) the same as :meth:`solve`
        followed by ``state.update``. Either way ``state`` ends exactly as
        ``state.update(q (+) dq, v)`` would leave it, with ``v = dq / dt`` when the state has
        a velocity and none otherwise.

        The state moves by the returned step whatever its status (as :meth:`step`); check
        ``result.success``. The state's previous ``q`` is not modified (``q`` arrays are
        never written in place). Each call returns a new result (a kept result is never
        changed by a later call).

        Args:
            state: current state, moved to the new configuration.
            dt: time step [s].
        """
        fast = self._lean_fast
        if fast is not None:  # the armed step in one C call (see NativeWeightedStack.arm_advance)
            try:
                result = fast(state, dt)
            except SolverError:  # H not positive definite (not moved): the path below
                result = False
            except (TypeError, ValueError, RuntimeError):
                self._native.require_targets()  # type: ignore[union-attr]
                raise
            if result:  # else None: the gate failed or the lock is held; False: see below
                return result  # type: ignore[no-any-return]
            if result is False:  # the active set did not settle (not moved): the Python path
                self._acquire()
                try:
                    return self._advance(state, dt)
                finally:
                    self._release()
        self._acquire()
        try:
            # the lean path: one kernel call, everything that depends only on the stack, the
            # tasks' assignments and the robot's version kept from the step that armed it
            # (_arm: the same dt, already checked; a state of this robot, checked below)
            if (
                dt.__class__ is float
                and dt == self._lean_dt
                and type(state) is State
                and _ASSIGNMENTS[0] == self._lean_assignments
                and state._robot is self.robot
                and self.robot._version == self._lean_version
            ):
                step = self._lean_step
                if step is not None:  # the kernel keeps the boxes, model, tasks and damping
                    t0 = _perf_counter()
                    try:
                        status, iterations, objective, build_time, qp_time, dq, q, v = step(
                            state._data,  # made by the state for this robot's model
                            state._q,
                            dt if state._has_velocity else 0.0,
                        )
                    except SolverError:  # H not positive definite (not moved)
                        self._lean_dt = _NAN
                        return self._advance(state, dt)
                    except (TypeError, ValueError, RuntimeError):
                        self._native.require_targets()  # type: ignore[union-attr]
                        raise
                    if dq is not None:  # the data hold the kinematics of q (a locked view)
                        state._adopt(q, v, True)
                        result = _new(IKStepResult)  # as below
                        result.success = True
                        result.status = _IK_SOLVED
                        result.dq = dq
                        result._velocity = None
                        result._dt = dt
                        result._qp = (
                            True,
                            _UNCONSTRAINED if status == 0 else _SOLVED,
                            dq,
                            objective,
                            iterations,
                            _perf_counter() - t0,
                            "native",
                        )
                        result.culprits = []
                        result.build_time = build_time
                        result.solve_time = qp_time
                        return result
                    self._lean_dt = _NAN  # the active set did not settle: the Python path
                    return self._advance(state, dt)
                native = self._native
                assert native is not None
                boxes = self._lean_boxes
                if boxes is None:
                    hard_boxes, soft_boxes = native.boxes(state, dt)
                else:
                    hard_boxes, soft_boxes = boxes
                has_velocity = state._has_velocity
                dq = _empty(self._nv)
                q_next = _empty(native.nq)
                v_next = _empty(self._nv) if has_velocity else native.no_velocity
                t0 = _perf_counter()
                try:
                    status, iterations, objective, build_time, qp_time, _ = native.advance(
                        native.model,
                        state._data,  # made by the state for this robot's model
                        state._q,
                        [t._target for t in native.tasks],
                        hard_boxes,
                        soft_boxes,
                        self._damping,
                        dq,
                        MAX_ACTIVE_SET_ITERATIONS,
                        q_next,
                        v_next,
                        dt if has_velocity else 0.0,
                        None,
                        None,
                    )
                except SolverError:  # H not positive definite (not moved)
                    self._lean_dt = _NAN
                    return self._advance(state, dt)
                except (TypeError, ValueError, RuntimeError):
                    native.require_targets()  # a task without a target: raises, naming it
                    raise
                if status != native.max_iterations:  # the data hold the kinematics of q_next
                    state._adopt(q_next, v_next if has_velocity else None)
                    # IKStepResult(True, SOLVED, dq, None, qp, None, build_time, qp_time,
                    # dt=dt) without its __init__ frame (its fields, nothing shared)
                    result = _new(IKStepResult)
                    result.success = True
                    result.status = _IK_SOLVED
                    result.dq = dq
                    result._velocity = None
                    result._dt = dt
                    # the QPResult's fields, made on first access of result.qp
                    result._qp = (
                        True,
                        _UNCONSTRAINED if status == 0 else _SOLVED,
                        dq,
                        objective,
                        iterations,
                        _perf_counter() - t0,
                        "native",
                    )
                    result.culprits = []
                    result.build_time = build_time
                    result.solve_time = qp_time
                    return result
                # the active set did not settle (the state has not moved): the Python path
                self._lean_dt = _NAN
            return self._advance(state, dt)
        finally:
            self._release()

    def _advance(self, state: State, dt: float) -> IKStepResult:
        """:meth:`advance` with every check (the caller holds the lock); arms the lean path."""
        if type(state) is not State and not isinstance(state, State):
            _require_state(state)
        if dt.__class__ is not float or not 0.0 < dt < _INF:  # NaN fails the comparison
            dt = check_positive(dt, "dt")
        self._lean_dt = _NAN
        self._lean_fast = None
        result = None
        if self._native is not None or (not self._native_checked and self.native):
            fused = self._fused
            result = self._solve_native(state, dt, fused)
            if fused and result is not None:  # the state has moved
                self._arm(dt)
                return result
            if result is None and self._native is not None:
                result = self._solve_python(state, dt)
                result._declined = self._native.declined
        if result is None:
            result = self._solve_python(state, dt)
        dq = result.dq
        state.update(
            _integrate(self.robot._model, state._q, dq),
            dq / dt if state._has_velocity else None,
            validate=False,
        )
        return result

    def _arm(self, dt: float) -> None:
        """Arm :meth:`advance`'s lean path after a fused step at ``dt`` (a checked float).

        Only for a stack without inequality rows nor Levenberg-Marquardt damping. What the
        step read and the lean path keeps: the tasks' weights, gains and damping (until some
        task attribute is assigned: ``taskspace.tasks.ASSIGNMENTS``), the kernel's copy of
        the position limits (until the robot's version changes), and the boxes when every
        box constraint declares that they do not read the state (``bounds_read_state``:
        until ``dt`` or the robot's version changes). With constant boxes the kernel itself
        keeps them with the model, the tasks and the damping (``NativeWeightedStack.arm``):
        the lean call then passes only the state's data, ``q`` and ``dt``.
        """
        native = self._native
        assert native is not None
        if native.has_rows or native._lm_damping:
            return
        self._lean_boxes = native.constant_boxes(dt)
        self._lean_step = native.arm(self._lean_boxes, self._damping)
        self._lean_assignments = native._assignments
        self._lean_version = self.robot._version
        self._lean_dt = dt
        if self._lean_step is not None:
            self._lean_fast = native.arm_advance(
                (
                    dt,
                    self.robot,
                    self._lean_version,
                    _ASSIGNMENTS,
                    self._lean_assignments,
                    self._lock,
                ),
                _RESULT_SLOTS,
            )

    def _solve_python(self, state: State, dt: float) -> IKStepResult:
        """:meth:`solve` by the Python path (the caller holds the lock)."""
        t0 = time.perf_counter()
        problem = self._build(state, dt)
        t1 = time.perf_counter()
        result = self.solver.solve(problem)
        if not result.success and result.status is not QPStatus.RELAXED:
            result = self._failed_step(problem, result)
        t2 = time.perf_counter()
        if result.success:
            status = IKStatus.SOLVED
        elif result.status is QPStatus.RELAXED:
            status = IKStatus.RELAXED
        else:
            status = IKStatus.FAILED
        dq = result.x
        culprits = self._culprits(problem, result, state, dt) if not result.success else []
        return IKStepResult(
            result.success, status, dq, None, result, culprits, t1 - t0, t2 - t1, dt=dt
        )

    def _failed_step(self, problem: QPProblem, result: QPResult) -> QPResult:
        """The answer to a QP the backends failed on (only on that path).

        First the same QP with its objective divided by the power of two ``2^e`` nearest its
        largest entry of ``H`` and ``g`` (exact: the minimizer is unchanged; the multipliers
        and the objective are multiplied back): a target 1e20 m away gives ``|g| ~ 1e19``
        next to ``|H| ~ 0.2`` and every backend failed (proxsuite returned ``|dq| ~ 1e13``),
        where the compiled kernel's box-corner step meets the KKT conditions exactly. The
        answer is accepted on its KKT residuals on the original problem (the solver's
        ``eps_abs``, ``eps_rel``).

        Else the failure's step respects the hard box: the backend's last iterate clipped to
        the box when it is within :data:`FAILED_STEP_BOX_TOLERANCE` of it, else the box's
        point nearest zero (zero when the box is empty). The backend's last iterate was
        returned as it was: ``|dq| ~ 1e13``, far outside the velocity box. The inequality
        rows are not guaranteed by it (the status says FAILED).
        """
        with np.errstate(over="ignore", invalid="ignore"):
            top = max(
                float(np.abs(problem.H).max(initial=0.0)), float(np.abs(problem.g).max(initial=0.0))
            )
        e = math.frexp(top)[1] if math.isfinite(top) and top > 0 else 0
        if e > 1:
            scaled = dataclasses.replace(
                problem, H=np.ldexp(problem.H, -e), g=np.ldexp(problem.g, -e), stacked=None
            )
            retry = self.solver.solve(scaled)
            if retry.success:
                y, z, zb = (np.ldexp(m, e) for m in (retry.y, retry.z, retry.z_box))
                if y.size == problem.n_eq and z.size == problem.n_in and zb.size == problem.n:
                    kkt = kkt_residuals(problem, retry.x, y, z, zb)
                    options = self.solver.options
                    if kkt.within(options.eps_abs, options.eps_rel):
                        retry.y, retry.z, retry.z_box, retry.kkt = y, z, zb, kkt
                        retry.objective = math.ldexp(retry.objective, e)
                        return retry
        lb, ub = problem.lb, problem.ub
        if not bool(np.all(lb <= ub)):  # an empty box (RELAXED normally): no step
            result.x = np.zeros(problem.n)
            return result
        x = result.x
        with np.errstate(over="ignore", invalid="ignore"):
            near = (
                bool(np.all(np.isfinite(x)))
                and float(np.max(np.maximum(lb - x, x - ub), initial=0.0))
                <= FAILED_STEP_BOX_TOLERANCE
            )
        result.x = np.clip(x if near else 0.0, lb, ub)
        return result

    def _solve_native(self, state: State, dt: float, move: bool = False) -> IKStepResult | None:
        """The kernel's step (``move``: and the state moved, see :meth:`advance`)."""
        if state._robot is not self.robot:  # the slot: cheaper than the read-only property
            self.tasks[0].feature._check_state(state)
        native = self._native
        assert native is not None
        t0 = _perf_counter()
        dq = _empty(self._nv)
        out = native.solve(state, dt, self._damping, dq, move)
        if out is None:
            return None
        status, iterations, objective, build_time, qp_time = out
        fields = (
            True,
            _UNCONSTRAINED if status == 0 else _SOLVED,
            dq,
            objective,
            iterations,
            _perf_counter() - t0,
            "native",
        )
        qp: QPResult | tuple[Any, ...] = fields  # made on first access of result.qp
        if native._general is not None:  # the general step: its residuals and multipliers
            fields = (*fields[:6], "native general")
            y, z, _, z_box = native.general_multipliers()
            # z is in the Python builder's row order only without kernel-evaluated rows
            z = z if not native._rows else _NO_Z
            qp = (*fields, [], {}, native.kernel.residuals(), y, z, z_box)
        elif native.has_rows:  # the kernel's own KKT residuals (the step is accepted on them)
            qp = (*fields, [], {}, native.kernel.residuals())  # made on first access
        elif self._native_residuals:  # (never with move: advance does not fuse then)
            qp = QPResult(*fields)
            qp.kkt = box_kkt_residuals(self._build(state, dt), dq)
        return IKStepResult(True, _IK_SOLVED, dq, None, qp, None, build_time, qp_time, dt=dt)

    def _culprits(self, problem: QPProblem, result: QPResult, state: State, dt: float) -> list[str]:
        """Constraints violated by the least-violating step, each box against its own bounds.

        The QP's box is the intersection of the box constraints; for ``result.conflict`` each
        box constraint becomes rows of its own (so a minimal conflict names only the boxes
        at fault, not all of them).
        """
        box_names = {blk.name for blk in problem.box_blocks}
        out = [name for name in result.culprits if name not in box_names]
        x = result.x
        boxes = []
        for c in self.constraints:
            box = c.bounds(state, dt)
            if box is None:
                continue
            lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
            boxes.append((c.name, lo, hi))
            if np.maximum(lo - x, x - hi).max() > 1e-6:
                out.append(c.name)
        source = result.conflict_problem
        if source is not None and boxes:
            result.conflict_problem = _separate_boxes(source, boxes)
        return out

    def step(self, state: State, dt: float) -> tuple[FloatArray, IKStepResult]:
        """Solve one step and return ``(q (+) dq, result)`` (the state is not modified)."""
        result = self.solve(state, dt)
        return np.asarray(pin.integrate(self.robot._model, state.q, result.dq)), result
