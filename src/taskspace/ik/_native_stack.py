"""The compiled path of :class:`~taskspace.ik.DifferentialIK` (``taskspace/_native/ik_kernel.cpp``).

It evaluates the same QP as :meth:`DifferentialIK.build` (task rows from the state's
Pinocchio data, ``H = M^T M + mu I``, boxes combined by the rules of
:func:`taskspace.qp.rows.combine_boxes`) and solves it exactly with a primal active-set
method on the box. It serves stacks whose every feature declares a
:class:`~taskspace.features.compiled.CompiledTerm` (frame poses, frame origins, the center of
mass, postures, frame orientations), with box constraints (joint position, velocity and
acceleration limits) and inequality rows whose constraints declare a
:class:`~taskspace.features.compiled.CompiledConstraint` (collision velocity dampers: coal
distances computed in the kernel). With rows, the box solution is kept when it satisfies
them; otherwise a primal-dual active-set method on the rows and the box runs from the box's
active set, and its step is accepted only when its KKT residuals meet the solver's
tolerances (they are carried on the result).

Equality tasks and the inequality rows of constraints that declare no rows the kernel
evaluates (:class:`~taskspace.constraints.FeatureBounds`, a user's rows) are evaluated in
Python (:class:`~taskspace.qp.rows.TaskRowStack`, :class:`~taskspace.qp.rows.InequalityStack`)
and the whole QP, with the kernel's task rows, box and dampers, is solved by the kernel's
general step (``taskspace/_native/general_step.hpp``: by default the dual active-set method of
the hierarchical kernel, equalities first, warm-started with the previous step's active set;
or proxsuite's dense solver in C++, see :meth:`NativeWeightedStack._choose_engine`); its step
is accepted only when its KKT residuals meet the solver's tolerances. A step the kernel
declines takes the Python path, and the result says why (:data:`DECLINED`,
``IKStepResult.native_declined``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from taskspace._native import ik_kernel
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError, SolverError
from taskspace.features.compiled import (
    IK_KINDS,
    CompiledConstraint,
    CompiledTerm,
    compiled_constraint,
    compiled_term,
)
from taskspace.model.collision_requests import without_cached_guess
from taskspace.model.robot import Robot
from taskspace.model.state import ADOPT_RESETS, State
from taskspace.model.versioning import ModelFollower
from taskspace.qp.kkt import KKTResiduals
from taskspace.qp.rows import InequalityStack, TaskRowStack
from taskspace.tasks import ASSIGNMENTS as _ASSIGNMENTS
from taskspace.tasks import Task

MAX_ACTIVE_SET_ITERATIONS = 200
_empty = np.empty


def _floats(a: Any) -> np.ndarray:
    """``a`` as a C-contiguous float array (itself when it is one)."""
    return np.ascontiguousarray(a, dtype=float)


# How each kind of term is registered with the kernel (the kernel's own API).
_REGISTER: dict[str, Callable[[Any, Any, CompiledTerm], Any]] = {
    "pose": lambda kernel, model, term: kernel.add_pose(model, term.frame_id),
    "position": lambda kernel, model, term: kernel.add_position(model, term.frame_id),
    "com": lambda kernel, model, term: kernel.add_com(),
    "posture": lambda kernel, model, term: kernel.add_posture(
        None if term.rows is None else list(term.rows)
    ),
    "orientation": lambda kernel, model, term: kernel.add_orientation(model, term.frame_id),
}


def weighted_kinds(module: Any) -> tuple[str, ...]:
    """The kinds of weighted terms the weighted kernel of ``module`` evaluates.

    :data:`IK_KINDS`, and frame orientations when the kernel has ``add_orientation`` (the
    hierarchical kernel does not: :data:`IK_KINDS` stays its list).
    """
    if hasattr(module.WeightedIKKernel, "add_orientation"):
        return (*IK_KINDS, "orientation")
    return IK_KINDS


GENERAL_ENGINES = ("auto", "active_set", "proxsuite")
"""QP engines of the general step (``DifferentialIKOptions.native_general_engine``)."""
# How each kind of equality task is registered with the kernel that evaluates the general
# step's equality rows (its weighted rows are the rows; no posture: that kind is a term of H)
_REGISTER_EQUALITY: dict[str, Callable[[Any, Any, CompiledTerm], Any]] = {
    "pose": _REGISTER["pose"],
    "position": _REGISTER["position"],
    "com": _REGISTER["com"],
    "orientation": lambda kernel, model, term: kernel.add_orientation(model, term.frame_id),
}
_FULL_TANGENT = frozenset({"posture"})
"""Kinds whose kernel rows span the whole tangent space (their scaling has nv entries, the
selected rows set); the kernel keeps them after the other terms."""


# How each kind of constraint rows is registered with the kernel (the kernel's own API).
_REGISTER_ROWS: dict[str, Callable[[Any, Robot, CompiledConstraint], Any]] = {
    "dampers": lambda kernel, robot, rows: kernel.add_dampers(
        robot._model,
        robot._collision_model,
        list(rows.pairs),
        rows.safety_distance,
        rows.influence_distance,
        rows.gain,
    ),
}


def _kernel_rows(c: Constraint) -> bool:
    """Whether ``c`` declares rows the weighted kernel evaluates itself (its class's own)."""
    rows = compiled_constraint(c)
    return rows is not None and rows.kind in _REGISTER_ROWS


def supported(
    tasks: Sequence[Task],
    inequality_constraints: Sequence[Constraint] = (),
    equality_tasks: Sequence[Task] = (),
) -> bool:
    """Whether the compiled kernel can run these tasks, constraints and equality tasks.

    The weighted tasks' features must declare a compiled term of :func:`weighted_kinds`. With
    the general step (``GeneralIKStep``, see ``taskspace/_native/general_step.hpp``) any
    equality tasks and inequality rows are served (the rows the kernel does not evaluate
    itself are evaluated in Python); a kernel built without it serves only inequality rows
    the kernel evaluates (collision dampers) and no equality tasks.
    """
    module = ik_kernel()
    if module is None or not tasks:
        return False
    kinds = weighted_kinds(module)
    if not all(
        (term := compiled_term(t.feature)) is not None and term.kind in kinds for t in tasks
    ):
        return False
    if hasattr(module, "GeneralIKStep"):
        return True
    return not equality_tasks and all(_kernel_rows(c) for c in inequality_constraints)


DECLINED = {
    2: "the compiled active-set method did not settle or its step missed the KKT tolerances",
    3: "the compiled general step found no point satisfying the equality, inequality and "
    "box rows (the dual active-set method: or it stopped at a degenerate vertex; proxsuite: "
    "its primal infeasibility test, which feasible problems with large multipliers can pass)",
    4: "the equality rows are linearly dependent (redundant or conflicting equality tasks)",
    5: "the compiled general step's KKT residuals exceed the solver's tolerances",
    6: "the QP's Hessian M^T M + mu I is not positive definite in floating point (damping 0 "
    "and a rank-deficient stack, or weights so far apart that mu I is lost in M^T M)",
    -1: "a task has Levenberg-Marquardt damping (the kernel's damping is fixed)",
}
"""Why the compiled weighted step declined (a kernel status, or -1), recorded on the Python
path's result as ``IKStepResult.native_declined``."""


class NativeWeightedStack:
    """Owns one compiled kernel for a fixed list of tasks and box constraints.

    The kernel is built for ``robot.model`` and only ever receives that model and the
    ``pin.Data`` of a :class:`~taskspace.model.State` made from it (a state's data cannot be
    replaced); a state of another model is refused before the kernel is called.

    Thread safety: not thread-safe (the kernel holds the QP workspace);
    :class:`~taskspace.ik.DifferentialIK` serializes its calls with its lock.
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Sequence[Task],
        constraints: Sequence[Constraint],
        inequality_constraints: Sequence[Constraint] = (),
        tolerances: tuple[float, float] = (1e-9, 1e-9),
        equality_tasks: Sequence[Task] = (),
        general_engine: str = "auto",
    ):
        module = ik_kernel()
        assert module is not None
        self.module = module
        model = robot._model
        self.robot = robot
        self.model = model
        kernel = module.WeightedIKKernel(robot.nv, robot.nq)
        terms: list[tuple[Task, CompiledTerm]] = []
        kinds = weighted_kinds(module)
        for t in tasks:
            term = compiled_term(t.feature)
            if term is None or term.kind not in kinds:
                raise InvalidInputError(
                    f"task '{t.name}': its feature declares no compiled term (use the Python "
                    "path: DifferentialIKOptions(native=False))"
                )
            terms.append((t, term))
        # the kernel keeps the full-tangent terms after the others (its row layout)
        terms = [p for p in terms if p[1].kind not in _FULL_TANGENT] + [
            p for p in terms if p[1].kind in _FULL_TANGENT
        ]
        for _, term in terms:
            _REGISTER[term.kind](kernel, model, term)
        self.kernel = kernel
        self.tasks = [t for t, _ in terms]
        self._terms = [term for _, term in terms]
        self._n_rows = sum(t.dim for t, term in terms if term.kind not in _FULL_TANGENT)
        self._n_full = sum(1 for term in self._terms if term.kind in _FULL_TANGENT)
        self._keys: list[tuple[Any, float]] = []
        self._assignments = -1  # tasks.ASSIGNMENTS when the tasks were last read
        self._lm_damping = False
        self._position, self._position_limits, self._hard, self._soft = split_boxes(
            robot, constraints, "compiled IK position limits", self._send_position_limits
        )
        self.nv = robot.nv
        # constraints with inequality rows the kernel evaluates (declared, sent again when
        # their declaration or the obstacle world changes); the other rows and the equality
        # tasks' rows are evaluated in Python and solved by the general step
        self._rows = [c for c in inequality_constraints if _kernel_rows(c)]
        python_rows = [c for c in inequality_constraints if not _kernel_rows(c)]
        self._general: Any = None
        self.general_engine = ""  # the general step's QP engine (none without it)
        if python_rows or equality_tasks:
            if not hasattr(module, "GeneralIKStep"):
                raise InvalidInputError(
                    "this build of the IK kernel has no general step (equality tasks, "
                    "inequality rows evaluated in Python): use the Python path, "
                    "DifferentialIKOptions(native=False), or rebuild taskspace"
                )
            self._general = module.GeneralIKStep()
            self.general_engine = self._choose_engine(general_engine)
            self._general.set_engine(module.GENERAL_ENGINES.index(self.general_engine))
        self._python_rows = InequalityStack(python_rows, robot.nv)
        # equality tasks whose feature declares a term the kernel evaluates: a second kernel
        # holding only them (its weighted rows are the equality rows); the others in Python
        evaluates = hasattr(module.WeightedIKKernel, "add_orientation")
        compiled_eq: list[tuple[Task, CompiledTerm]] = []
        python_eq: list[Task] = []
        for t in equality_tasks:
            term = compiled_term(t.feature)
            if (
                evaluates
                and term is not None
                and term.kind in _REGISTER_EQUALITY
                and type(t).rows is Task.rows
            ):
                compiled_eq.append((t, term))
            else:
                python_eq.append(t)
        self._eq_kernel: Any = None
        self._eq_tasks = [t for t, _ in compiled_eq]
        self._eq_terms = [term for _, term in compiled_eq]
        self._eq_keys: list[tuple[Any, float]] = []
        if compiled_eq:
            self._eq_kernel = module.WeightedIKKernel(robot.nv, robot.nq)
            for _, term in compiled_eq:
                _REGISTER_EQUALITY[term.kind](self._eq_kernel, model, term)
        self._equalities = TaskRowStack(python_eq, robot.nv) if python_eq else None
        # the equality rows' order in the kernel (compiled tasks, then Python ones) as rows
        # of the Python builder (equality tasks in the given order): y_builder[order] = y
        starts = np.cumsum([0] + [t.dim for t in equality_tasks])
        index = {id(t): k for k, t in enumerate(equality_tasks)}
        self._eq_order = np.concatenate(
            [np.zeros(0, dtype=int)]
            + [
                np.arange(starts[index[id(t)]], starts[index[id(t)] + 1])
                for t in [*self._eq_tasks, *python_eq]
            ]
        )
        self._eq_permuted = bool((self._eq_order != np.arange(len(self._eq_order))).any())
        # one Python constraint with rows: its rows passed as they are (the kernel checks
        # and copies them), without the stack's buffers
        self._single_rows = python_rows[0] if len(python_rows) == 1 else None
        self.declined = ""  # why the last solve returned None (DECLINED)
        # each class's own declaration (compiled_constraint checked it is the class's own)
        self._declare = [c.compiled_constraint for c in self._rows]
        self._declared: list[CompiledConstraint | None] = []
        self._world_version = -1
        self._geometry: tuple[Any, ...] = ()  # (collision model, its data) with rows
        kernel.set_tolerances(*tolerances)
        # whether the kernel evaluates inequality rows (its solves carry KKT residuals): fixed
        # at construction, a plain attribute (read at every step)
        self.has_rows = bool(self._rows) or self._general is not None
        # without rows, the kernel's 9-argument solve under its own name (no overload dispatch,
        # no collision arguments): the step of a box-only stack costs what it did before the
        # dampers were added; with rows, the 11-argument solve
        # (a kernel built before solve_boxes existed: its 9-argument solve overload)
        self._kernel_solve = (
            self._solve_with_rows if self._rows else getattr(kernel, "solve_boxes", kernel.solve)
        )
        self.max_iterations = module.MAX_ITERATIONS
        # the fused step (solve, integrate, kinematics of the new q): one signature, the
        # collision model and its data always given (None without rows)
        # (the general step's: the same fused step, called by _solve_general)
        self.advance: Any = (
            self._general.advance if self._general else getattr(kernel, "advance", None)
        )
        self._advance_geometry: tuple[Any, Any] = (None, None)
        self.nq = robot.nq
        self.no_velocity = np.zeros(0)  # v_next of a state without velocity (not written)
        # whether every box the stack evaluates in Python declares that it does not read the
        # state (its class's own bounds_read_state = False): constant_boxes can keep them
        self._constant = all(
            type(c).__dict__.get("bounds_read_state", True) is False
            for c in (*self._hard, *self._soft)
        )

    def _choose_engine(self, engine: str) -> str:
        """The QP engine of the general step: ``engine``, or the one ``"auto"`` chooses.

        The engines (``taskspace/_native/general_step.hpp``), both certified by the same KKT
        check of the step (``eps_abs + eps_rel * scale`` of the solver's tolerances):

        * ``"active_set"``: the hierarchical kernel's dual active-set method (Goldfarb-Idnani,
          equalities first), warm-started: the QP is first solved with the previous step's
          active rows held (one Cholesky of ``H``, one of their Schur complement, one
          refinement step), and that point is kept only when every row holds and no active
          row's multiplier is negative (then it is the minimizer); otherwise the method runs
          from the unconstrained minimizer;
        * ``"proxsuite"``: proxsuite's dense solver in C++ with the settings of
          :class:`~taskspace.qp.QPSolverOptions`' defaults, one workspace per problem size
          kept between steps (preconditioner not recomputed, previous result as initial
          guess), its point then solved exactly on its active set.

        ``"auto"`` chooses ``"active_set"`` for every problem class the general step serves
        (weighted stacks with equality tasks, with a user's rows or feature bounds, with
        collision dampers, on arms and floating-base humanoids, with a few or dozens of
        active rows): the project's default QP backend is proxsuite, but the warm-started
        active-set method was faster on each of these classes, with the same answers and KKT
        residuals (``python -m benchmarks.run qp_backends``, sets ``general ...``; with
        dozens of rows active proxsuite beats the active-set method started cold, not the
        warm-started one).
        """
        if engine not in GENERAL_ENGINES:
            raise InvalidInputError(
                f"general step engine must be one of {GENERAL_ENGINES}, got {engine!r}"
            )
        available = tuple(self.module.GENERAL_ENGINES)
        if engine == "auto":
            return "active_set"
        if engine not in available:
            raise InvalidInputError(
                f"general step engine {engine!r} is not in this build of the IK kernel "
                f"(available: {available})"
            )
        return engine

    def _check_tasks(self) -> None:
        """Read the tasks' weights, gains and LM damping (after an assignment to a task)."""
        self._assignments = _ASSIGNMENTS[0]
        tasks = self.tasks
        self._lm_damping = any(t.lm_damping for t in tasks)
        keys = self._keys
        if not keys or any(
            t.sqrt_weight is not w or t.gain is not g for t, (w, g) in zip(tasks, keys)
        ):
            self._scale()
        if self._eq_kernel is not None and (
            not self._eq_keys
            or any(
                t.sqrt_weight is not w or t.gain is not g
                for t, (w, g) in zip(self._eq_tasks, self._eq_keys)
            )
        ):
            w = np.zeros(sum(t.dim for t in self._eq_tasks))
            c = np.zeros_like(w)
            k = 0
            for t, term in zip(self._eq_tasks, self._eq_terms):
                k = write_scaling(w, c, k, t, term, self.nv)
            self._eq_kernel.set_scaling(w, c)
            self._eq_keys = [(t.sqrt_weight, t.gain) for t in self._eq_tasks]

    def _send_position_limits(self, position: Any) -> None:
        self.kernel.set_position_limits(*position.kernel_arguments())

    def _scale(self) -> None:
        """Send the rows' weights and gains to the kernel (when a task's were reassigned)."""
        keys = [(t.sqrt_weight, t.gain) for t in self.tasks]
        nv = self.nv
        w = np.zeros(self._n_rows + nv * self._n_full)
        c = np.zeros_like(w)
        k = 0
        for t, term in zip(self.tasks, self._terms):
            k = write_scaling(w, c, k, t, term, nv)
        self.kernel.set_scaling(w, c)
        self._keys = keys

    def solve(
        self, state: State, dt: float, damping: float, out: np.ndarray, move: bool = False
    ) -> tuple[int, int, float, float, float] | None:
        """``(status, iterations, objective, build_time, qp_time)``; the step is written to ``out``.

        ``None`` when the active set did not settle, or a task has Levenberg-Marquardt damping
        (the kernel's damping is fixed): the caller takes the Python path, and ``state`` is
        unchanged.

        ``move``: the kernel's ``advance`` (one call): after the solve it integrates
        ``q (+) dq`` and recomputes the kinematics of ``state``'s data there, exactly as
        :meth:`State.update` does (with the velocity ``dq / dt`` when the state has one); the
        state then adopts the new ``q`` (and ``v``) and marks what it derived from the old
        kinematics stale (:meth:`State._adopt`).
        """
        model = self.model
        if state._model is not model:  # the kernel must never see a Data of another model
            raise InvalidInputError(
                f"this IK solver is built for robot '{self.robot.name}'; the state belongs to "
                f"robot '{state.robot.name}': make the state with this robot's state(q)"
            )
        # the tasks' weights, gains and Levenberg-Marquardt damping are read again only after
        # an assignment to some task (the kernel's damping is fixed: LM damping takes the
        # Python path; reassigned weights or gains are sent again)
        if _ASSIGNMENTS[0] != self._assignments:
            self._check_tasks()
        if self._lm_damping:
            self.declined = DECLINED[-1]
            return None
        targets = [t._target for t in self.tasks]
        if self._position_limits is not None:
            self._position_limits.sync()
        if self._rows:  # collision rows: their declarations (the solve adds the geometry)
            self._sync_rows()
        hard_boxes, soft_boxes = self.boxes(state, dt)
        args = (
            model,
            state._data,  # made by the state for ``state._model``, cannot be replaced
            state._q,
            targets,
            hard_boxes,
            soft_boxes,
            damping,
            out,
            MAX_ACTIVE_SET_ITERATIONS,
        )
        if self._general is not None:
            return self._solve_general(state, dt, args, move)
        try:
            if move:
                q_next = _empty(self.nq)
                has_velocity = state._has_velocity
                v_next = _empty(self.nv) if has_velocity else self.no_velocity
                geometry = self._advance_geometry
                status, iterations, objective, t_build, t_qp, _ = self.advance(
                    *args,
                    q_next,
                    v_next,
                    dt if has_velocity else 0.0,
                    geometry[0],
                    geometry[1],
                )
                if status != self.max_iterations:  # the data hold the kinematics of q_next
                    state._adopt(q_next, v_next if has_velocity else None)
            else:
                status, iterations, objective, t_build, t_qp, _ = self._kernel_solve(*args)
        except SolverError:
            # the kernel's Cholesky of H failed (the state has not moved): the Python path's
            # QP solver takes the same problem (a singular H is fine for it when the QP is)
            self.declined = DECLINED[6]
            return None
        except (TypeError, ValueError, RuntimeError):
            self.require_targets()
            raise
        if status == self.max_iterations:
            self.declined = DECLINED[2]
            return None
        return status, iterations, objective, t_build, t_qp

    def _solve_general(
        self, state: State, dt: float, args: tuple[Any, ...], move: bool
    ) -> tuple[int, int, float, float, float] | None:
        """:meth:`solve` by the general step.

        The equality rows and the inequality rows the kernel does not evaluate come from
        Python; the kernel solves them with its own rows and box.
        """
        equalities = None
        if self._equalities is not None:
            equalities = self._equalities.velocity(state)
        inequalities = None
        single = self._single_rows
        if single is not None:
            rows = single.inequalities(state, dt)
            if rows is not None and len(rows[0]):
                inequalities = (_floats(rows[0]), _floats(rows[1]), _floats(rows[2]))
        elif self._python_rows:
            rows, blocks = self._python_rows.fill(state, dt)
            if blocks:
                inequalities = rows
        geometry = self._geometry if self._rows else (None, None)
        general_rows = (
            self._eq_kernel,
            [t._target for t in self._eq_tasks],
            equalities,
            inequalities,
        )
        try:
            if move:
                q_next = _empty(self.nq)
                has_velocity = state._has_velocity
                v_next = _empty(self.nv) if has_velocity else self.no_velocity
                status, iterations, objective, t_build, t_qp, _ = self._general.advance(
                    self.kernel,
                    *args[:8],
                    *geometry,
                    general_rows,
                    q_next,
                    v_next,
                    dt if has_velocity else 0.0,
                )
                if status <= 1:  # the data hold the kinematics of q_next
                    state._adopt(q_next, v_next if has_velocity else None)
            else:
                status, iterations, objective, t_build, t_qp, _ = self._general.solve(
                    self.kernel, *args[:8], *geometry, general_rows
                )
        except (TypeError, ValueError, RuntimeError):
            self.require_targets()
            raise
        if status > 1:
            self.declined = DECLINED[status]
            return None
        return status, iterations, objective, t_build, t_qp

    def general_multipliers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Multipliers of the general step's last solve, signed as proxsuite's.

        ``(y, z, z_dampers, z_box)``: of the equality rows (the equality tasks' rows, in
        order), of the inequality rows evaluated in Python (the constraints' rows in order,
        without the kernel's own), of the kernel's damper rows (:meth:`damper_rows`) and of
        the box.
        """
        y, z, zd, zb = self._general.multipliers()  # new 1-D arrays (eigenpy's vectors)
        if self._eq_permuted:
            y_builder = np.empty_like(y)
            y_builder[self._eq_order] = y
            y = y_builder
        return y, z, zd, zb

    def boxes(self, state: State, dt: float) -> tuple[list[Any], list[Any]]:
        """The hard and soft boxes evaluated in Python (the kernel evaluates the position box)."""
        hard, soft = self._hard, self._soft
        hard_boxes = [b for c in hard if (b := c.bounds(state, dt)) is not None] if hard else []
        soft_boxes = [b for c in soft if (b := c.bounds(state, dt)) is not None] if soft else []
        return hard_boxes, soft_boxes

    def constant_boxes(self, dt: float) -> tuple[list[Any], list[Any]] | None:
        """:meth:`boxes` at ``dt`` when no box reads the state, else ``None``.

        Valid while ``dt`` and the robot's version are unchanged (``bounds_read_state``).
        """
        if not self._constant:
            return None
        hard = [b for c in self._hard if (b := c.bounds(None, dt)) is not None]  # type: ignore[arg-type]
        soft = [b for c in self._soft if (b := c.bounds(None, dt)) is not None]  # type: ignore[arg-type]
        return hard, soft

    def arm(
        self, boxes: tuple[list[Any], list[Any]] | None, damping: float
    ) -> Callable[..., Any] | None:
        """The kernel's armed step ``step(data, q, dt or 0)``, or ``None``.

        ``boxes``: :meth:`constant_boxes` at some ``dt`` (``None``: a box reads the state).
        The kernel keeps the model, the tasks (it reads their targets at each call), these
        boxes, the damping and the iteration limit: valid while ``dt``, the tasks'
        assignments and the robot's version are those the boxes were made for (the caller
        arms again when one changes). ``None`` (nothing kept): boxes that read the state,
        inequality rows, or a kernel built before ``arm`` existed.
        """
        kernel = self.kernel
        if boxes is None or self._rows or not hasattr(kernel, "arm"):
            return None
        hard, soft = boxes
        kernel.arm(self.model, list(self.tasks), hard, soft, damping, MAX_ACTIVE_SET_ITERATIONS)
        step: Callable[..., Any] = kernel.step
        return step

    def arm_advance(
        self, gate: tuple[Any, ...], result: tuple[Any, ...]
    ) -> Callable[..., Any] | None:
        """After :meth:`arm`: the whole armed ``DifferentialIK.advance`` as one C function.

        ``advance(state, dt)`` checks ``gate``, runs the armed step on the state's data and
        ``q``, records the new ``q`` (and ``v``) in the state as :meth:`State._adopt` does
        (:data:`~taskspace.model.state.ADOPT_RESETS`) and returns a new result; ``None``
        (nothing done) when the gate does not hold or the solver's lock is held, ``False`` when
        the active set did not settle (the state has not moved). The lock is not taken: the
        function checks it is free right before it uses the kernel's workspaces and runs no
        Python code from there until the step is written (so no other thread runs).

        ``gate``: ``(dt, robot, robot's version, tasks.ASSIGNMENTS, its value, lock)``;
        ``result``: the result class, its slots' member descriptors ``success, status, dq,
        _velocity, _dt, _qp, culprits, build_time, solve_time`` and the constants
        ``IKStatus.SOLVED, QPStatus.UNCONSTRAINED, QPStatus.SOLVED, "native"``. ``None``: a
        kernel built before ``arm_advance`` existed.
        """
        kernel = self.kernel
        if not hasattr(kernel, "arm_advance"):
            return None
        slots = State.__dict__
        none, cleared, false = ADOPT_RESETS
        state = (
            State,
            *(slots[name] for name in ("_robot", "_data", "_q", "_v", "_has_velocity", "_a0")),
            tuple(slots[name] for name in none),
            tuple(slots[name] for name in cleared),
            tuple(slots[name] for name in false),
        )
        advance: Callable[..., Any] = kernel.arm_advance(gate, state, result)
        return advance

    def require_targets(self) -> None:
        """Raise, naming it, when a task has no target (after the kernel refused its call)."""
        for t in [*self.tasks, *self._eq_tasks]:
            t._require_target()

    def _solve_with_rows(self, *args: Any) -> Any:
        """The kernel's 11-argument solve: ``args`` and the collision model with its data."""
        return self.kernel.solve(*args, *self._geometry)

    def residuals(self) -> KKTResiduals:
        """KKT residuals of the last solve with rows (the kernel's, see ``taskspace.qp.kkt``)."""
        return KKTResiduals(*self.kernel.residuals())

    def damper_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int], list[float]]:
        """The kernel's inequality rows of the last solve: ``(C, l, u, pairs, distances)``.

        ``pairs`` are the indices into ``robot.collision_model.collisionPairs`` of the rows
        and ``distances`` their coal distances [m] (for inspection and tests).
        """
        C, l, u, pairs, distances = self.kernel.damper_rows()
        m = len(pairs)
        return (
            np.asarray(C).reshape(m, self.nv),
            np.asarray(l).reshape(m),
            np.asarray(u).reshape(m),
            list(pairs),
            list(distances),
        )

    def multipliers(self) -> tuple[np.ndarray, np.ndarray]:
        """Multipliers of the last solve: of the rows (``<= 0``) and of the box (size nv)."""
        z, z_box = self.kernel.multipliers()
        return np.asarray(z).reshape(-1), np.asarray(z_box).reshape(-1)

    def _sync_rows(self) -> None:
        """Send the rows' declarations again when they or the obstacle world changed."""
        robot = self.robot
        version = robot._world._version  # per step: the attributes, not the properties
        if version == self._world_version:
            for declare, before in zip(self._declare, self._declared):
                if declare() is not before:
                    break
            else:
                return
        declared = [declare() for declare in self._declare]
        kernel = self.kernel
        kernel.clear_dampers()
        geometry = robot._collision_model
        for c, rows in zip(self._rows, declared):
            if rows is None or rows.kind not in _REGISTER_ROWS:
                raise InvalidInputError(
                    f"constraint '{c.name}' no longer declares compiled rows (use the Python "
                    "path: DifferentialIKOptions(native=False))"
                )
            _REGISTER_ROWS[rows.kind](kernel, robot, rows)
        if version != self._world_version:  # a data of the collision model as it is now
            # cached GJK guesses off, as everywhere else (distances independent of history)
            self._geometry = (geometry, without_cached_guess(geometry.createData()))
            self._advance_geometry = self._geometry
        self._world_version = version
        self._declared = declared


def _has_bounds(c: Constraint) -> bool:
    return type(c).bounds is not Constraint.bounds


def write_scaling(
    w: np.ndarray, c: np.ndarray, k: int, task: Task, term: CompiledTerm, nv: int
) -> int:
    """Write a task's row weights ``sqrt_weight`` and gains ``-gain * sqrt_weight`` at row ``k``.

    A full-tangent (posture) term takes ``nv`` rows, of which only its selected ``rows`` when
    it has some; another term its task's ``dim`` rows. Returns the next row.
    """
    if term.kind in _FULL_TANGENT and term.rows is not None:
        sel = k + np.asarray(term.rows, dtype=int)
        w[sel] = task.sqrt_weight
        c[sel] = -task.gain * np.asarray(task.sqrt_weight)
        return k + nv
    d = nv if term.kind in _FULL_TANGENT else task.dim
    w[k : k + d] = task.sqrt_weight
    c[k : k + d] = -task.gain * np.asarray(task.sqrt_weight)
    return k + d


def split_boxes(
    robot: Robot, constraints: Sequence[Constraint], what: str, send: Callable[[Any], None]
) -> tuple[Constraint | None, ModelFollower | None, list[Constraint], list[Constraint]]:
    """The constraints with a box, for a compiled kernel: ``(position, follower, hard, soft)``.

    The first joint-position box is evaluated by the kernel from q (a class that declares
    ``kernel_arguments`` itself: a subclass may change the box); the kernel keeps a copy of its
    limits, which ``follower`` sends (``send(position)``) now and after ``Robot.set_limits``.
    The other boxes are evaluated in Python, split into hard and soft ones.
    """
    boxes = [c for c in constraints if _has_bounds(c)]
    position = next((c for c in boxes if "kernel_arguments" in type(c).__dict__), None)
    follower: ModelFollower | None = None
    if position is not None:
        follower = ModelFollower(robot, what, lambda: send(position))
        boxes.remove(position)
    return (
        position,
        follower,
        [c for c in boxes if c.hard_bounds],
        [c for c in boxes if not c.hard_bounds],
    )
