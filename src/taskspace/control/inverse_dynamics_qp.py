"""Inverse-dynamics QP: operational-space control with torque limits and contacts.

Slides 5:31-5:35.

Decision variables ``x = (a, f)``: joint accelerations and contact forces. Torques are
eliminated, ``tau = S (M a + h - J_c^T f)``, so the problem reads

``min  sum_i rho_i |J_i a + Jdot_i v - y''_i*|^2 + lambda_a |a|^2 + lambda_f |W f|^2 / (m g)^2``
``s.t. (M a + h - J_c^T f)_u = 0``            (unactuated rows: floating base, passive joints)
``     J_c a + Jdot_c v = -kd J_c v (- kp e_c)``  (rigid contacts)
``     K f >= k``                                (linearized friction cones, CoP)
``     tau_min <= S (M a + h - J_c^T f) <= tau_max``
``     a_min <= a <= a_max``                     (joint position and velocity limits)

with ``y''* = y''_ref - kp e - kd e'`` per task. Without contacts on a fixed-base robot this is
the operational-space controller of slide 5:34 as a QP with torque limits. Tasks are weighted
in one QP, or strictly prioritized (``hierarchical=True``: dynamics and contacts first, then
the task priorities, as a cascade of QPs of any depth).

Thread safety: :class:`InverseDynamicsQP` serializes its calls with a lock (see there);
:class:`InverseDynamicsOptions` and :class:`InverseDynamicsStatus` are immutable; an
:class:`InverseDynamicsResult` is plain result data, not locked. A :class:`CenterOfPressureTask` is
mutable and not locked: its ``target``/``weight``/``priority`` setters replace one attribute at
a time (a reader sees the old or the new value), so set them from the thread that steps the
controller.
"""

from __future__ import annotations

import enum
import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NoReturn, cast

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector, check_int, check_positive
from taskspace.constraints.contact import Contact, Contact6D
from taskspace.control._native_idqp import NativeInverseDynamics, unsupported
from taskspace.errors import InvalidInputError
from taskspace.model.robot import Robot
from taskspace.model.state import State
from taskspace.model.versioning import ModelFollower
from taskspace.qp.hierarchy import HierarchyLevel, HierarchyOptions, HierarchySolver
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus
from taskspace.qp.rows import TaskRowStack, combine_boxes
from taskspace.qp.solver import RELAXED_VIOLATION, QPSolver, QPSolverOptions
from taskspace.tasks import Task


class InverseDynamicsStatus(enum.Enum):
    """Outcome of an inverse-dynamics step."""

    SOLVED = "solved"
    RELAXED = "relaxed"
    FAILED = "failed"


@dataclass
class InverseDynamicsResult:
    """Result of one inverse-dynamics step.

    Attributes:
        success: every constraint satisfied.
        status: see :class:`InverseDynamicsStatus`.
        a: joint accelerations (nv) [rad/s^2, m/s^2].
        tau: joint torques (nv; zero on unactuated rows) [N m, N].
        forces: contact forces by contact frame (6-D wrench in the contact frame, or 3-D
            world force) [N, N m].
        qp: QP result of the weighted problem (``None`` in hierarchical mode).
        residuals: per priority level, the task residual norm (hierarchical mode).
        level_results: per level of the cascade, its QP result with KKT residuals
            (hierarchical mode; empty levels solved without a QP are ``UNCONSTRAINED``).
        culprits: constraint blocks at fault when the problem was relaxed (every block the
            least-violating point violates; ``qp.conflict`` of the weighted QP: a minimal
            conflicting subset).
        build_time, solve_time: wall times [s].
        compiled: the step was computed by the compiled kernel (``InverseDynamicsOptions.
            native``); ``qp.backend`` then says which of its solves answered.
        contacts: frames of the contacts active in this step (the keys of ``forces``, in
            the QP's order).
        releasing: contacts being removed (:meth:`InverseDynamicsQP.remove_contact`) and the
            upper bound of their normal force in this step [N].
    """

    success: bool
    status: InverseDynamicsStatus
    a: FloatArray
    tau: FloatArray
    forces: dict[str, FloatArray]
    qp: QPResult | None = None
    residuals: list[float] = field(default_factory=list)
    level_results: list[QPResult] = field(default_factory=list)
    culprits: list[str] = field(default_factory=list)
    build_time: float = 0.0
    solve_time: float = 0.0
    compiled: bool = False
    contacts: tuple[str, ...] = ()
    releasing: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class InverseDynamicsOptions:
    """Settings of :class:`InverseDynamicsQP`.

    Attributes:
        acceleration_regularization: ``lambda_a`` [s^4/rad^2].
        force_regularization: ``lambda_f``, relative to the robot's weight: the cost is
            ``lambda_f |W f|^2 / (m g)^2`` with ``m g`` the robot's weight [N] and ``W`` the
            contacts' relative weights (torques of 6-D contacts weighted by the inverse
            squared sole half-sizes, see ``Contact6D.regularization_weights``). The term
            makes the split of forces between redundant contacts unique, but it also pulls
            the forces toward zero and the centers of pressure toward the sole centers, while
            balance needs them under the CoM: the QP then gives up a task acceleration error
            (for a CoM task, an offset of that error over ``kp``) that grows with
            ``lambda_f``. The default ``1e-2`` keeps that offset below a millimetre on a
            standing humanoid with ``kp = 10``; much smaller values make the force block of
            the Hessian ill-conditioned (on G1, ``1e-2`` is ``9.3e-8 W`` [1/N^2]), which
            first-order backends (proxsuite) need many more iterations for.
        torque_limits: enforce ``|tau| <= effort limits``.
        joint_limits: bound accelerations so joints stop within their position and
            velocity limits over ``limits_horizon``.
        limits_horizon: look-ahead of the joint-limit bounds [s], in
            ``[MIN_LIMITS_HORIZON, MAX_LIMITS_HORIZON]`` (1e-6 to 1e6 s).
        hierarchical: strict priorities (task ``priority``) instead of weights.
        solver: QP solver settings of the weighted problem (default daqp, proxsuite as
            fallback: on the G1 benchmark, with cones or limits active in half the steps,
            daqp took 446 us per step and proxsuite 518 us).
        solver_for_hierarchy: use ``solver`` for the cascade's levels too (default: the
            cascade's own: daqp kept when exact to 1e-9, else proxsuite with
            :data:`~taskspace.qp.hierarchy.CASCADE_SOLVER_OPTIONS`).
        native: run the weighted step on the compiled kernel (``taskspace/_native``) when it
            is built and serves the controller: every task's feature declares a compiled term
            (frame pose, orientation, frame origin, center of mass, posture), every contact a
            compiled kind (:class:`~taskspace.constraints.Contact6D`,
            :class:`~taskspace.constraints.PointContact`), no center-of-pressure task, positive
            regularizations (``InverseDynamicsQP.native_reason`` says why not). The kernel
            builds the same QP and reports a step only with KKT residuals within ``solver``'s
            tolerances (``eps_abs``, ``eps_rel``); any other step runs the Python path.
    """

    acceleration_regularization: float = 1e-6
    force_regularization: float = 1e-2
    torque_limits: bool = True
    joint_limits: bool = True
    limits_horizon: float = 0.05
    hierarchical: bool = False
    solver: QPSolverOptions = field(
        default_factory=lambda: QPSolverOptions(backend="daqp", fallbacks=("proxsuite",))
    )
    solver_for_hierarchy: bool = False
    native: bool = True

    def __post_init__(self) -> None:
        """Refuse regularizations that are negative or not finite (a clear error, not a NaN QP)."""
        check_positive(
            self.acceleration_regularization, "acceleration_regularization", strict=False
        )
        check_positive(self.force_regularization, "force_regularization", strict=False)
        h = check_positive(self.limits_horizon, "limits_horizon")
        if not MIN_LIMITS_HORIZON <= h <= MAX_LIMITS_HORIZON:
            # 2 / T^2 overflows (or 2 / T underflows) outside: a ZeroDivisionError, or an
            # infinite joint-limit box that silently removed the limits
            raise InvalidInputError(
                f"limits_horizon must be in [{MIN_LIMITS_HORIZON:g}, {MAX_LIMITS_HORIZON:g}] s, "
                f"got {self.limits_horizon!r}"
            )


MIN_LIMITS_HORIZON = 1e-6
"""Smallest ``InverseDynamicsOptions.limits_horizon`` [s]."""
MAX_LIMITS_HORIZON = 1e6
"""Largest ``InverseDynamicsOptions.limits_horizon`` [s]."""


class CenterOfPressureTask:
    """Drive the center of pressure of a 6-D contact to a point ``p*`` of its sole.

    With the contact wrench ``(f, tau)`` in the contact frame, the center of pressure is
    ``p = (-tau_y / f_z, tau_x / f_z)``; the task is the linear least-squares term
    ``weight (|tau_x - p*_y f_z|^2 + |tau_y + p*_x f_z|^2) / (m g)^2`` on the force
    variables (``m g``: the robot's weight [N], as in the force regularization), which is zero
    exactly when ``p = p*`` (TSID's ``TaskCopEquality``). In hierarchical mode
    (``InverseDynamicsOptions(hierarchical=True)``) its two rows, scaled by ``sqrt(weight) /
    (m g)``, join the level of its ``priority`` beside the tasks of that priority (a level of
    their own if no task has it).

    Attributes:
        contact: the :class:`~taskspace.constraints.Contact6D` whose center of pressure is
            driven.
        name: label.

    ``target`` (``p*`` in the contact frame, x and y [m], on the sole:
    ``|x| <= half_length``, ``|y| <= half_width``), ``weight`` (precision, finite
    and ``>= 0``) and ``priority`` (level in a strict hierarchy, an integer ``>= 0``, 0 the
    highest; ignored in weighted mode) are properties validated on assignment.
    """

    def __init__(
        self,
        contact: Contact6D,
        target: object = (0.0, 0.0),
        *,
        weight: float = 1.0,
        priority: int = 0,
        name: str | None = None,
    ) -> None:
        if not isinstance(contact, Contact6D):
            raise InvalidInputError(
                "CenterOfPressureTask needs a Contact6D (a sole with a 6-D wrench), got "
                f"{type(contact).__name__}"
            )
        self.contact = contact
        self.name = name or f"center of pressure({contact.frame})"
        self.target = target  # type: ignore[assignment]
        self.weight = weight
        self.priority = priority

    @property
    def priority(self) -> int:
        """Level in a strict hierarchy (0 = highest; ignored in weighted mode)."""
        return self._priority

    @priority.setter
    def priority(self, value: int) -> None:
        p = check_int(value, f"priority of '{self.name}'")
        if p < 0:
            raise InvalidInputError(f"priority of '{self.name}' must be >= 0, got {p}")
        self._priority = p

    @property
    def target(self) -> FloatArray:
        """``p*`` (x, y) in the contact frame [m]."""
        return self._target

    @target.setter
    def target(self, value: object) -> None:
        target = as_vector(value, 2, f"target of '{self.name}'")
        hx, hy = self.contact.half_length, self.contact.half_width
        if abs(target[0]) > hx or abs(target[1]) > hy:
            # a center of pressure is a point of the sole: no contact wrench has another
            raise InvalidInputError(
                f"target of '{self.name}' ({target[0]:g}, {target[1]:g}) m is outside the sole "
                f"of contact '{self.contact.frame}' (|x| <= {hx:g}, |y| <= {hy:g} m): a center "
                "of pressure lies on the sole"
            )
        self._target = target

    @property
    def weight(self) -> float:
        """Precision of the task."""
        return self._weight

    @weight.setter
    def weight(self, value: float) -> None:
        self._weight = check_positive(value, f"weight of '{self.name}'", strict=False)

    def rows(self) -> FloatArray:
        """``R`` (2 x 6) with ``R (f, tau) = (tau_x - p*_y f_z, tau_y + p*_x f_z)``."""
        px, py = self._target
        return np.array([[0.0, 0.0, -py, 1.0, 0.0, 0.0], [0.0, 0.0, px, 0.0, 1.0, 0.0]])


def _fixed(name: str) -> NoReturn:
    raise InvalidInputError(
        f"InverseDynamicsQP.{name} is fixed at construction (the QP's rows, buffers and "
        f"compiled kernel are derived from it): build a new InverseDynamicsQP with the new {name}"
    )


@dataclass
class _Release:
    """A contact being removed: its normal-force bound ramps from ``f_start`` to 0.

    Step ``k`` (1 to ``steps``) of the controller after :meth:`InverseDynamicsQP.
    remove_contact` bounds the normal force by ``f_start (1 - k / steps)``; the step after the
    last one no longer has the contact.
    """

    contact: Contact
    f_start: float
    steps: int
    done: int = 0

    @property
    def limit(self) -> float:
        return self.f_start * max(0.0, 1.0 - self.done / self.steps)


def _normal_index(contact: Contact) -> int:
    """Which force variable of ``contact`` is its normal force (``Contact.normal_force``)."""
    e = np.eye(contact.force_dim)
    hits = [i for i in range(contact.force_dim) if contact.normal_force(e[i]) == 1.0]
    if len(hits) != 1:
        raise InvalidInputError(
            f"contact '{contact.frame}': its normal_force is not one force variable, so it "
            "cannot be released smoothly (use remove_contact(..., transition_time=0))"
        )
    return hits[0]


def _as_index(indices: np.ndarray) -> slice | np.ndarray:
    """A slice when ``indices`` are consecutive (faster indexing), else the array."""
    if indices.size and np.all(np.diff(indices) == 1):
        return slice(int(indices[0]), int(indices[-1]) + 1)
    return indices


class InverseDynamicsQP:
    """Acceleration-level task-space control with contacts and limits (see module docstring).

    Thread safety: the controller keeps its QP buffers and solver workspaces, so the calls
    of several threads run one at a time (a lock); each thread needs its own
    :class:`~taskspace.model.State`.

    Compiled step: in weighted mode the step runs on the compiled kernel
    (``taskspace/_native/idqp_kernel.cpp``) when every task's feature and every contact declare
    that the kernel serves them (``native_reason`` is then empty; see
    ``InverseDynamicsOptions.native``). It builds the same QP as :meth:`build` and answers with
    the equality-constrained minimizer when that violates nothing, else with proxsuite's dense
    solver refined on its active set; a step is reported only with KKT residuals within the
    solver options' tolerances (``result.qp.kkt``), any other runs the Python path
    (``result.compiled`` says which path answered).

    Model version: the controller follows :meth:`Robot.set_limits
    <taskspace.model.Robot.set_limits>`; the next step after a change rebuilds the torque-limit
    rows, the actuated/unactuated split and the joint-limit bounds from the new limits.
    ``tasks``, ``pressure_tasks`` and ``options`` are fixed at construction (tuples; assigning
    them raises :class:`~taskspace.errors.InvalidInputError`): a different set is a new
    controller. ``contacts`` changes only through :meth:`add_contact` and
    :meth:`remove_contact` (with a smooth force transition, as TSID's
    ``removeRigidContact(name, transition_duration)``); each change rebuilds the QP's buffers,
    solver workspaces and compiled kernel (``contacts_version`` counts the changes). Targets,
    gains, weights, contact references and normal-force limits are read at every step.

    Args:
        robot: the robot.
        tasks: tasks with targets and PD gains (``Task.kp``, ``Task.kd``).
        contacts: active contacts.
        options: settings.
        pressure_tasks: center-of-pressure tasks on some of ``contacts``.
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Sequence[Task],
        contacts: Sequence[Contact] = (),
        options: InverseDynamicsOptions | None = None,
        pressure_tasks: Sequence[CenterOfPressureTask] = (),
    ) -> None:
        self.robot = robot
        # fixed at construction (tuples, no setters): the QP's rows, buffers and the compiled
        # kernel are derived from them; a changed set of tasks or contacts is a new controller
        self._tasks: tuple[Task, ...] = tuple(tasks)
        self._contacts: tuple[Contact, ...] = tuple(contacts)
        if options is not None and not isinstance(options, InverseDynamicsOptions):
            raise InvalidInputError(  # a dict raised a bare AttributeError
                f"options must be an InverseDynamicsOptions, got {type(options).__name__}"
            )
        self._options = options or InverseDynamicsOptions()
        for t in self._tasks:
            if not isinstance(t, Task):
                raise InvalidInputError(f"tasks must be Task objects, got {type(t).__name__}")
        for c in self._contacts:
            if not isinstance(c, Contact):
                raise InvalidInputError(
                    "contacts must be Contact objects (Contact6D, PointContact), got "
                    f"{type(c).__name__}"
                )
        self._pressure_tasks: tuple[CenterOfPressureTask, ...] = tuple(pressure_tasks)
        for pt in self.pressure_tasks:
            if not isinstance(pt, CenterOfPressureTask):
                raise InvalidInputError(
                    f"pressure_tasks must be CenterOfPressureTask objects, got {type(pt).__name__}"
                )
            if not any(pt.contact is c for c in self.contacts):
                raise InvalidInputError(
                    f"'{pt.name}': its contact is not one of this controller's contacts "
                    f"({[c.name for c in self.contacts]})"
                )
        check_positive(self.options.limits_horizon, "limits_horizon")
        if not self.tasks:
            raise InvalidInputError("InverseDynamicsQP needs at least one task")
        for t in self.tasks:
            if t.feature.robot is not robot:
                raise InvalidInputError(f"task '{t.name}' is defined on another robot")
        for c in self.contacts:
            if c.robot is not robot:
                raise InvalidInputError(f"contact '{c.name}' is defined on another robot")
        frames = [c.frame for c in self.contacts]
        if len(set(frames)) != len(frames):
            raise InvalidInputError(f"two contacts on the same frame: {frames}")
        # contacts being removed (remove_contact with a transition), by frame
        self._releases: dict[str, _Release] = {}
        self._last_forces: dict[str, FloatArray] = {}
        self.contacts_version = 0
        # everything derived from the robot's limits (effort: which rows are actuated;
        # position/velocity limits: the acceleration box), again after robot.set_limits
        self._follower = ModelFollower(robot, "InverseDynamicsQP", self._setup)
        self._lock = threading.Lock()
        self._acquire = self._lock.acquire
        self._release = self._lock.release

    @property
    def tasks(self) -> tuple[Task, ...]:
        """The tasks (fixed at construction; their targets, gains and weights may change)."""
        return self._tasks

    @tasks.setter
    def tasks(self, value: object) -> None:
        _fixed("tasks")

    @property
    def contacts(self) -> tuple[Contact, ...]:
        """The active contacts (see :meth:`add_contact`, :meth:`remove_contact`)."""
        return self._contacts

    @contacts.setter
    def contacts(self, value: object) -> None:
        raise InvalidInputError(
            "InverseDynamicsQP.contacts cannot be assigned (like the tasks, the set is fixed at "
            "construction except through add_contact(contact) and remove_contact(frame, "
            "transition_time=..., dt=...), which rebuild the QP)"
        )

    def add_contact(self, contact: Contact) -> None:
        """Make ``contact`` active from the next step on (a touchdown).

        The QP gets its force variables, acceleration rows and cone rows: the buffers, the
        solver workspaces (their warm starts) and the compiled kernel are rebuilt. Anchor the
        contact first (``contact.set_reference(state)``) when it has a position gain. A load
        that should build up gradually is ``contact.max_normal_force`` raised step by step
        (a contact built with ``max_force``).
        """
        if not isinstance(contact, Contact):
            raise InvalidInputError(
                f"add_contact needs a Contact (Contact6D, PointContact), got "
                f"{type(contact).__name__}"
            )
        if contact.robot is not self.robot:
            raise InvalidInputError(f"contact '{contact.name}' is defined on another robot")
        self._acquire()
        try:
            if any(c.frame == contact.frame for c in self._contacts):
                raise InvalidInputError(
                    f"a contact on frame '{contact.frame}' is already active "
                    f"(active: {[c.frame for c in self._contacts]})"
                )
            self._contacts = (*self._contacts, contact)
            self._rebuild()
        finally:
            self._release()

    def remove_contact(
        self, frame: str | Contact, transition_time: float = 0.0, dt: float | None = None
    ) -> None:
        """Remove the contact on ``frame``, at once or after a force transition (a lift-off).

        With ``transition_time = 0`` the next step has no such contact. Otherwise the
        contact stays for ``steps = max(1, round(transition_time / dt))`` more calls of
        :meth:`solve` (``dt``: the control period [s]) while the upper bound of its normal
        force ramps linearly from ``f_start`` down to 0 (step ``k`` bounds it by
        ``f_start (1 - k / steps)``; its minimum force is 0 meanwhile; ``f_start``: its normal
        force at the last step, at most its ``normal_force_limit``; before any step that limit or
        the robot's weight), so the other contacts
        take the load over gradually, as TSID's ``removeRigidContact(name,
        transition_duration)`` lowers the contact's maximum normal force; the step after the last
        one has no such contact. Each step's result lists the bound in ``releasing``.

        ``frame`` may also be the :class:`~taskspace.constraints.Contact` itself (its frame is
        used).
        """
        if isinstance(frame, Contact):  # was "no active contact on frame <...object at 0x..>"
            frame = frame.frame
        self._acquire()
        try:
            active = [c.frame for c in self._contacts]
            if frame not in active:
                raise InvalidInputError(f"no active contact on frame {frame!r}; active: {active}")
            contact = self._contacts[active.index(frame)]
            for pt in self.pressure_tasks:
                if pt.contact is contact:
                    raise InvalidInputError(
                        f"'{pt.name}' drives the center of pressure of contact '{frame}': "
                        "a controller with that task cannot remove the contact"
                    )
            T = check_positive(transition_time, "transition_time", strict=False)
            if frame in self._releases:
                raise InvalidInputError(f"contact '{frame}' is already being removed")
            if T == 0.0:
                self._drop(frame)
                return
            if dt is None:
                raise InvalidInputError(
                    "remove_contact with a transition_time needs dt, the control period [s] "
                    "(one call of solve advances the transition by dt)"
                )
            step = check_positive(dt, "dt")
            ratio = T / step
            if not math.isfinite(ratio):  # round(inf): a bare OverflowError
                raise InvalidInputError(
                    f"transition_time / dt = {transition_time!r} / {dt!r} is not a finite "
                    "number of control steps"
                )
            steps = max(1, round(ratio))
            _normal_index(contact)  # refuses contacts without one normal force variable
            top = contact.normal_force_limit
            last = self._last_forces.get(frame)
            f0 = (
                contact.normal_force(last)
                if last is not None
                else (self._weight if top is None else top)
            )
            if top is not None:
                f0 = min(f0, top)
            self._releases[frame] = _Release(contact, max(f0, 0.0), steps)
            self._rebuild()  # the contact's cone gets its transition rows
        finally:
            self._release()

    @property
    def releasing(self) -> dict[str, float]:
        """Contacts being removed with a transition, and their normal-force bound [N].

        The bound of the last :meth:`solve` (of the next one before the first); a contact whose
        transition ended (bound 0) is still listed, and still in :attr:`contacts`, until the
        next :meth:`solve` drops it.
        """
        self._acquire()
        try:
            return {f: r.limit for f, r in self._releases.items()}
        finally:
            self._release()

    def _drop(self, frame: str) -> None:
        self._contacts = tuple(c for c in self._contacts if c.frame != frame)
        self._releases.pop(frame, None)
        self._rebuild()

    def _rebuild(self) -> None:
        """Everything sized by the contacts: buffers, workspaces, the compiled kernel."""
        self._setup()
        self.contacts_version += 1

    def _advance_releases(self) -> None:
        """One step of every transition; contacts whose transition ended are dropped."""
        for frame in [f for f, r in self._releases.items() if r.done >= r.steps]:
            self._drop(frame)
        for r in self._releases.values():
            r.done += 1

    def _cone(self, contact: Contact) -> tuple[FloatArray, FloatArray, int | None]:
        """``(K, k, limit row)`` of ``contact`` in this controller.

        The contact's own cone, except while it is being removed: then its minimum normal
        force is 0 and it has an upper-bound row (appended if it had none) set every step.
        """
        K, k = contact.cone()
        row = contact.max_force_row
        if contact.frame not in self._releases:
            return K, k, row
        K, k = np.array(K, dtype=float), np.array(k, dtype=float)
        e = np.zeros(contact.force_dim)
        e[_normal_index(contact)] = 1.0
        k[np.all(K == e, axis=1) & (k > 0)] = 0.0  # the minimum-force row
        if row is None:
            K = np.vstack([K, -e])
            k = np.append(k, 0.0)
            row = K.shape[0] - 1
        return K, k, row

    def _normal_force_limit(self, contact: Contact) -> float:
        """The upper bound of the normal force in this step (rows of :meth:`_cone`)."""
        r = self._releases.get(contact.frame)
        if r is not None:
            return r.limit
        return cast(float, contact.normal_force_limit)

    @property
    def pressure_tasks(self) -> tuple[CenterOfPressureTask, ...]:
        """The center-of-pressure tasks (fixed at construction)."""
        return self._pressure_tasks

    @pressure_tasks.setter
    def pressure_tasks(self, value: object) -> None:
        _fixed("pressure_tasks")

    @property
    def options(self) -> InverseDynamicsOptions:
        """The settings (fixed at construction; :class:`InverseDynamicsOptions` is frozen)."""
        return self._options

    @options.setter
    def options(self, value: object) -> None:
        _fixed("options")

    def _setup(self) -> None:
        """Build the QP's buffers and constant blocks from the robot's current model.

        Called at construction and again, by the :class:`~taskspace.model.versioning.
        ModelFollower`, at the first step after :meth:`Robot.set_limits
        <taskspace.model.Robot.set_limits>`: the effort limits decide which rows are actuated
        (dynamics equalities, torque-limit rows) and the position and velocity limits the
        acceleration box, so the whole problem is rebuilt (the solver workspaces too).
        """
        robot = self.robot
        nv = robot.nv
        effort = robot.effort_limits
        self.actuated = np.flatnonzero(effort > 0)
        self.unactuated = np.flatnonzero(effort <= 0)
        self._effort = effort[self.actuated]
        self._neg_effort = -self._effort
        self.nf = sum(c.force_dim for c in self.contacts)
        self._contact_frames = tuple(c.frame for c in self.contacts)
        self.n = nv + self.nf
        self._data = robot._model.createData()
        self._last: tuple[FloatArray, FloatArray, FloatArray] | None = None
        self._upper = np.triu(np.ones((nv, nv), dtype=bool))
        self._solver = QPSolver(self.options.solver)
        self._hierarchy = HierarchySolver(
            HierarchyOptions(solver=self.options.solver)
            if self.options.solver_for_hierarchy
            else None
        )
        # static blocks: cone rows
        cones = [self._cone(c) for c in self.contacts]
        n_cone = sum(K.shape[0] for K, _, _ in cones)
        self._cone_C = np.zeros((n_cone, self.n))
        self._cone_l = np.zeros(n_cone)
        r, col = 0, nv
        # rows -f_n >= -limit that follow Contact.normal_force_limit at every step (contact
        # transitions: set_normal_force_limit ramps a foot's force down before lift-off)
        self._limit_rows: list[tuple[int, Contact]] = []
        for (K, k, limit_row), c in zip(cones, self.contacts):
            self._cone_C[r : r + K.shape[0], col : col + c.force_dim] = K
            self._cone_l[r : r + K.shape[0]] = k
            if limit_row is not None:
                self._limit_rows.append((r + limit_row, c))
            r += K.shape[0]
            col += c.force_dim
        weight = pin.computeTotalMass(robot._model) * float(
            np.linalg.norm(robot._model.gravity.linear)
        )
        force_weights = (
            np.concatenate([c.regularization_weights() for c in self.contacts])
            / max(weight, 1e-9) ** 2
            if self.contacts
            else np.zeros(0)
        )
        self._reg = np.diag(
            np.concatenate(
                [
                    np.full(nv, self.options.acceleration_regularization),
                    self.options.force_regularization * force_weights,
                ]
            )
        )
        self._task_rows = TaskRowStack(self.tasks, nv)
        self._level_key: tuple[int, ...] | None = None
        self._levels: list[HierarchyLevel] = []
        self._level_slices: list[tuple[slice, list[CenterOfPressureTask]]] = []
        self._level_rows = self._task_rows
        # per-step buffers, refilled in place (the force block of H is constant)
        self._H = self._reg.copy()
        self._weight = weight
        self._force_cols = {
            id(c): slice(nv + start, nv + start + c.force_dim)
            for c, start in zip(
                self.contacts, np.cumsum([0] + [c.force_dim for c in self.contacts])
            )
        }
        self._HJ = np.zeros((nv, nv))
        self._g = np.zeros(self.n)
        self._lb = np.full(self.n, -INF)
        self._ub = np.full(self.n, INF)
        self._Jc = np.zeros((self.nf, nv))
        self._contact_rows = []
        row = 0
        for c in self.contacts:
            self._contact_rows.append((c, slice(row, row + c.force_dim)))
            row += c.force_dim
        self._contact_neg_kd = np.zeros(self.nf)
        self._contact_kd: list[float | None] = [None] * len(self.contacts)
        self._u = _as_index(self.unactuated)
        self._act = _as_index(self.actuated)
        nu, nc = len(self.unactuated), self.nf
        n_tau = len(self.actuated) if self.options.torque_limits else 0
        n_cone = self._cone_C.shape[0]
        # Every constraint as lo <= G x <= hi, G = [C; A; unit rows of the limited joints]:
        # C, l, u, A and b are views into G, lo and hi (one product tests feasibility).
        n_in, n_eq = n_cone + n_tau, nu + nc
        box = robot.limited_joints_v if self.options.joint_limits else np.zeros(0, dtype=int)
        self._G = np.zeros((n_in + n_eq + box.size, self.n))
        self._G[n_in + n_eq + np.arange(box.size), box] = 1.0
        self._lo = np.full(self._G.shape[0], -INF)
        self._hi = np.full(self._G.shape[0], INF)
        self._C = self._G[:n_in]
        self._C[:n_cone] = self._cone_C
        self._l = self._lo[:n_in]
        self._l[:n_cone] = self._cone_l
        self._u_bound = self._hi[:n_in]
        self._A = self._G[n_in : n_in + n_eq]
        self._b = self._lo[n_in : n_in + n_eq]
        self._b_hi = self._hi[n_in : n_in + n_eq]
        self._box_lo = self._lo[n_in + n_eq :]
        self._box_hi = self._hi[n_in + n_eq :]
        self._eq_blocks = ([RowBlock("unactuated dynamics", 0, nu)] if nu else []) + [
            RowBlock(c.name, nu + k, nu + k + c.force_dim)
            for c, k in zip(self.contacts, np.cumsum([0] + [c.force_dim for c in self.contacts]))
        ]
        self._in_blocks = ([RowBlock("friction cones", 0, n_cone)] if n_cone else []) + (
            [RowBlock("torque limits", n_cone, n_cone + n_tau)] if n_tau else []
        )
        self._problem = QPProblem(
            self._H,
            self._g,
            self._A,
            self._b,
            self._C,
            self._l,
            self._u_bound,
            self._lb,
            self._ub,
            self._eq_blocks,
            self._in_blocks,
            [RowBlock("joint limits", 0, nv)],
            stacked=(self._G, self._lo, self._hi),
            convex=True,  # the regularization plus the tasks' J^T W J (weights >= 0)
        )
        iq, iv = robot.limited_joints_q, robot.limited_joints_v
        self._limit_iq, self._limit_iv = _as_index(iq), _as_index(iv)
        # the compiled step, when the controller's objects declare that the kernel serves them
        self.native_reason = unsupported(self)
        self._native = None if self.native_reason else NativeInverseDynamics(self)
        # joint-limit acceleration bounds (see _acceleration_bounds), constant parts
        horizon = self.options.limits_horizon
        self._limit_c = 2.0 / (horizon * horizon)
        self._limit_c_lo = self._limit_c * robot.lower_limits[iq]
        self._limit_c_hi = self._limit_c * robot.upper_limits[iq]
        self._limit_vmax_T = robot.velocity_limits[iv] / horizon
        self._limit_neg_vmax_T = -self._limit_vmax_T

    # ------------------------------------------------------------------ assembly
    def _refresh_contact_gains(self) -> None:
        """Per-row ``-kd`` of the contacts (re-read when a contact's ``kd`` changed)."""
        for i, (c, rows) in enumerate(self._contact_rows):
            if c.kd is not self._contact_kd[i]:
                self._contact_neg_kd[rows] = -c.kd
                self._contact_kd[i] = c.kd

    def _dynamics(self, state: State) -> tuple[FloatArray, FloatArray, FloatArray]:
        model, data = self.robot._model, self._data
        M = pin.crba(model, data, state.q)  # only the upper triangle is meaningful
        M = np.where(self._upper, M, M.T)
        h = pin.nonLinearEffects(model, data, state.q, state.v)
        Jc = self._Jc
        for c, rows in self._contact_rows:
            Jc[rows] = c.jacobian(state)
        self._last = (M, h, Jc)  # reused by _result
        return M, h, Jc

    def _acceleration_bounds(self, state: State) -> tuple[FloatArray, FloatArray]:
        """Acceleration bounds (size n, refilled in place; force entries stay infinite)."""
        lb, ub = self._lb, self._ub
        if not self.options.joint_limits:
            return lb, ub
        T = self.options.limits_horizon
        iv = self._limit_iv
        q, v = state.q[self._limit_iq], state.v[iv]
        # stop at the position limit within the horizon: q + v T + a T^2 / 2 in [lo, hi],
        # i.e. c (lo - q) - 2 v / T <= a <= c (hi - q) - 2 v / T with c = 2 / T^2,
        # and keep |v + a T| <= v_max: (-v_max - v) / T <= a <= (v_max - v) / T
        shift = self._limit_c * q
        shift += (2.0 / T) * v
        v_T = v / T
        # both boxes are physical: where they conflict (already violating), the midpoint
        position = (self._limit_c_lo - shift, self._limit_c_hi - shift)
        velocity = (self._limit_neg_vmax_T - v_T, self._limit_vmax_T - v_T)
        lo, hi = combine_boxes((position, velocity), (), v.shape[0])
        lb[iv] = lo
        ub[iv] = hi
        self._box_lo[:] = lo
        self._box_hi[:] = hi
        return lb, ub

    def _diagnose_bounds(self, state: State, exc: InvalidInputError) -> None:
        """Name the joints whose limit bounds left the representable range (raise), if any.

        A state far outside the robot's range (a velocity of 1e20 rad/s) puts the joint-limit
        acceleration bounds beyond ``INF``: the QP then refused a lower bound of ``+inf`` or
        an upper bound of ``-inf``, which says nothing of the state.
        """
        if not self.options.joint_limits:
            return
        lo, hi = self._box_lo, self._box_hi
        bad = np.flatnonzero((lo >= INF) | (hi <= -INF) | ~np.isfinite(lo) | ~np.isfinite(hi))
        if not bad.size:
            return
        model = self.robot._model
        owner = {
            model.joints[j].idx_v + k: model.names[j]
            for j in range(1, model.njoints)
            for k in range(model.joints[j].nv)
        }
        iv = np.arange(self.robot.nv)[self._limit_iv][bad]
        names = list(dict.fromkeys(owner[int(i)] for i in iv))
        raise InvalidInputError(
            f"the joint-limit acceleration bounds of {names} are beyond {INF:g}: the state "
            f"is far outside the robot's range (|v| up to {float(np.abs(state.v[iv]).max()):.3g}"
            f" there, limits_horizon {self.options.limits_horizon:g} s); check the state"
        ) from exc

    def build(self, state: State) -> QPProblem:
        """The weighted QP at ``state`` (needs the state's velocity).

        The same :class:`QPProblem` object is returned at every call: its arrays are buffers
        refilled in place by the next ``build`` (copy them to keep a snapshot).
        """
        self._acquire()
        try:
            return self._build(state)
        finally:
            self._release()

    def _build(self, state: State) -> QPProblem:
        """:meth:`build` without the lock (the caller holds it)."""
        self._follower.sync()  # one integer comparison; rebuilds after robot.set_limits
        if not state.has_velocity:
            raise InvalidInputError(
                "inverse dynamics needs the velocity: use robot.state(q, v) / state.update(q, v)"
            )
        nv = self.robot.nv
        M, h, Jc = self._dynamics(state)
        Jt, rt = self._task_rows.acceleration(state)
        # H = reg + [Jt^T Jt, 0; 0, 0] (the force block is the constant regularization)
        HJ = self._HJ
        np.dot(Jt.T, Jt, out=HJ)
        HJ.flat[:: nv + 1] += self.options.acceleration_regularization
        H = self._H
        H[:nv, :nv] = HJ
        if self.pressure_tasks:
            H[nv:, nv:] = self._reg[nv:, nv:]
            scale = 1.0 / max(self._weight, 1e-9) ** 2
            for pt in self.pressure_tasks:
                R = pt.rows()
                cols = self._force_cols[id(pt.contact)]
                H[cols, cols] += (pt.weight * scale) * R.T.dot(R)
        g = self._g
        np.negative(Jt.T.dot(rt), out=g[:nv])
        self._equalities(state, M, h, Jc)
        self._inequalities(M, h, Jc)
        self._acceleration_bounds(state)
        return self._problem  # its arrays are the buffers refilled above

    def _equalities(
        self, state: State, M: FloatArray, h: FloatArray, Jc: FloatArray
    ) -> tuple[FloatArray, FloatArray, list[RowBlock]]:
        nv = self.robot.nv
        u = self._u
        nu = len(self.unactuated)
        A, b = self._A, self._b
        if nu:
            A[:nu, :nv] = M[u]
            np.negative(Jc[:, u].T, out=A[:nu, nv:])
            np.negative(h[u], out=b[:nu])
        A[nu:, :nv] = Jc
        if self.nf:
            # b_c = -kd J_c v - Jdot_c v (- kp e_c): one product for all contacts
            self._refresh_contact_gains()
            b_c = b[nu:]
            np.multiply(Jc.dot(state.v), self._contact_neg_kd, out=b_c)
            for c, rows in self._contact_rows:
                b_c[rows] -= c.drift(state)
                if c.kp and c.reference is not None:
                    b_c[rows] -= c.kp * c.position_error(state)
        self._b_hi[:] = b
        return A, b, self._eq_blocks

    def _inequalities(
        self, M: FloatArray, h: FloatArray, Jc: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, list[RowBlock]]:
        nv = self.robot.nv
        C, l, u = self._C, self._l, self._u_bound
        n_cone = self._cone_C.shape[0]
        for row, contact in self._limit_rows:
            l[row] = -self._normal_force_limit(contact)  # max_force unless lowered
        if self.options.torque_limits and len(self.actuated):
            act = self._act
            C[n_cone:, :nv] = M[act]
            np.negative(Jc[:, act].T, out=C[n_cone:, nv:])
            h_act = h[act]
            np.subtract(self._neg_effort, h_act, out=l[n_cone:])
            np.subtract(self._effort, h_act, out=u[n_cone:])
        return C, l, u, self._in_blocks

    def reset(self) -> None:
        """Forget what the solvers keep between steps (warm starts, active sets).

        The next step then solves as the first one did: the same states give the same
        results, bit for bit (an episode of a Gymnasium env after ``reset(seed=...)``).
        """
        self._acquire()
        try:
            self._solver = QPSolver(self.options.solver)
            self._hierarchy = HierarchySolver(
                HierarchyOptions(solver=self.options.solver)
                if self.options.solver_for_hierarchy
                else None
            )
            if self._native is not None:
                self._native = NativeInverseDynamics(self)
        finally:
            self._release()

    # ------------------------------------------------------------------ solve
    def solve(self, state: State) -> InverseDynamicsResult:
        """One control step: accelerations, contact forces and torques at ``state``."""
        self._acquire()  # bound methods: about half the cost of ``with self._lock``
        try:
            if self._releases:
                self._advance_releases()
            out = self._solve(state)
            out.contacts = self._contact_frames
            if self._releases:
                out.releasing = {f: r.limit for f, r in self._releases.items()}
            self._last_forces = out.forces  # remove_contact starts its ramp there
            return out
        finally:
            self._release()

    def _solve(self, state: State) -> InverseDynamicsResult:
        t0 = time.perf_counter()
        if self.options.hierarchical:
            return self._solve_hierarchical(state, t0)
        self._follower.sync()  # one integer comparison; rebuilds after robot.set_limits
        native = self._native
        if native is not None:
            if state._model is not native.model:  # the kernel must never see another Data
                namesake = (
                    " (another Robot object of the same name)"
                    if state.robot.name == self.robot.name
                    else ""
                )
                raise InvalidInputError(
                    f"this controller is built for robot '{self.robot.name}'; the state belongs "
                    f"to robot '{state.robot.name}'{namesake}: make the state with this robot's "
                    "state(q, v)"
                )
            if not state.has_velocity:
                raise InvalidInputError(
                    "inverse dynamics needs the velocity: use robot.state(q, v) / "
                    "state.update(q, v)"
                )
            out = native.solve(state)
            if out is not None:
                qp, tau, t_build, t_solve = out
                x = qp.x
                nv = self.robot.nv
                return InverseDynamicsResult(
                    True,
                    InverseDynamicsStatus.SOLVED,
                    x[:nv].copy(),
                    tau,
                    {
                        c.frame: x[nv + rows.start : nv + rows.stop].copy()
                        for c, rows in self._contact_rows
                    },
                    qp,
                    build_time=t_build,
                    solve_time=t_solve,
                    compiled=True,
                )
        problem = self._build(state)
        t1 = time.perf_counter()
        try:
            result = self._solver.solve(problem)
        except InvalidInputError as exc:
            self._diagnose_bounds(state, exc)
            raise
        t2 = time.perf_counter()
        if result.success:
            status = InverseDynamicsStatus.SOLVED
        elif result.status is QPStatus.RELAXED:
            status = InverseDynamicsStatus.RELAXED
        else:
            status = InverseDynamicsStatus.FAILED
        return self._result(state, result.x, result.success, status, t1 - t0, t2 - t1, result)

    def _solve_hierarchical(self, state: State, t0: float) -> InverseDynamicsResult:
        self._follower.sync()  # one integer comparison; rebuilds after robot.set_limits
        if not state.has_velocity:
            raise InvalidInputError(
                "inverse dynamics needs the velocity: use robot.state(q, v) / state.update(q, v)"
            )
        nv, n = self.robot.nv, self.n
        M, h, Jc = self._dynamics(state)
        A, b, _ = self._equalities(state, M, h, Jc)
        C, l, u, in_blocks = self._inequalities(M, h, Jc)
        levels = self._hierarchy_levels()
        Jt, rt = self._level_rows.acceleration(state)
        scale = 1.0 / max(self._weight, 1e-9)
        for level, (rows, cops) in zip(levels, self._level_slices):
            if not cops:
                level.J[:, :nv] = Jt[rows]  # level.r is a view into the stack's rhs
                continue
            d = rows.stop - rows.start  # task rows, then two rows per center-of-pressure task
            level.J[:d, :nv] = Jt[rows]
            level.r[:d] = rt[rows]
            for i, pt in enumerate(cops):
                block = level.J[d + 2 * i : d + 2 * i + 2]
                block[:, self._force_cols[id(pt.contact)]] = np.sqrt(pt.weight) * scale * pt.rows()
        lb, ub = self._acceleration_bounds(state)
        t1 = time.perf_counter()
        try:
            result = self._hierarchy.solve(
                levels, n, lb=lb, ub=ub, C=C, l=l, u=u, hard_names=in_blocks, A=A, b=b
            )
        except InvalidInputError as exc:
            self._diagnose_bounds(state, exc)
            raise
        t2 = time.perf_counter()
        status = InverseDynamicsStatus.SOLVED if result.success else InverseDynamicsStatus.RELAXED
        out = self._result(state, result.x, result.success, status, t1 - t0, t2 - t1, None)
        out.residuals = result.residuals
        out.level_results = result.level_results
        if not result.success:
            # the hard blocks the cascade's point violates (the buffers of self._problem hold
            # this step's A, b, C, l, u and bounds), as the weighted QP's relaxation names
            # them, then the cascade's own diagnostics (rows no level could satisfy)
            # (the cascade names the same inequality blocks, and the bounds as "bounds")
            violations = self._problem.violations(result.x)
            names = [name for name, v in violations.items() if v > RELAXED_VIOLATION]
            out.culprits = names + [
                c
                for c in result.culprits
                if c not in violations and c not in ("bounds", "hard equalities")
            ]
        return out

    def _hierarchy_levels(self) -> list[HierarchyLevel]:
        """Levels of the cascade (one per priority, then the force regularization).

        Built once (again if a task's priority changed): their arrays are buffers refilled at
        every step, the task rows by one :class:`~taskspace.qp.rows.TaskRowStack` ordered by
        priority, then two rows per center-of-pressure task of that priority (on its contact's
        force variables, right-hand side 0).
        """
        key = tuple(t.priority for t in self.tasks) + tuple(
            -1 - pt.priority for pt in self.pressure_tasks
        )
        if key == self._level_key:
            return self._levels
        nv, n = self.robot.nv, self.n
        ordered = sorted(self.tasks, key=lambda t: t.priority)
        self._level_rows = TaskRowStack(ordered, nv)
        levels, slices, row = [], [], 0
        priorities = {t.priority for t in self.tasks} | {pt.priority for pt in self.pressure_tasks}
        for p in sorted(priorities):
            d = sum(t.dim for t in ordered if t.priority == p)
            rows = slice(row, row + d)
            cops = [pt for pt in self.pressure_tasks if pt.priority == p]
            r = self._level_rows.rhs[rows] if not cops else np.zeros(d + 2 * len(cops))
            levels.append(HierarchyLevel(f"priority {p}", np.zeros((r.size, n)), r))
            slices.append((rows, cops))
            row += d
        # last level: force regularization (distributes forces when contacts are redundant)
        if self.nf:
            w = np.sqrt(np.diag(self._reg)[nv:])
            reg = np.hstack([np.zeros((self.nf, nv)), np.diag(w)])
            levels.append(HierarchyLevel("force regularization", reg, np.zeros(self.nf)))
        self._levels, self._level_slices, self._level_key = levels, slices, key
        return levels

    def _result(
        self,
        state: State,
        x: FloatArray,
        success: bool,
        status: InverseDynamicsStatus,
        build_time: float,
        solve_time: float,
        qp: QPResult | None,
    ) -> InverseDynamicsResult:
        nv = self.robot.nv
        a, f = x[:nv], x[nv:]
        M, h, Jc = self._dynamics(state) if self._last is None else self._last
        tau_full = M.dot(a)
        tau_full += h
        if self.nf:
            tau_full -= Jc.T.dot(f)
        tau = np.zeros(nv)
        tau[self._act] = tau_full[self._act]
        forces = {c.frame: f[rows].copy() for c, rows in self._contact_rows}
        return InverseDynamicsResult(
            success,
            status,
            a.copy(),
            tau,
            forces,
            qp,
            culprits=list(qp.culprits) if qp is not None else [],
            build_time=build_time,
            solve_time=solve_time,
        )
