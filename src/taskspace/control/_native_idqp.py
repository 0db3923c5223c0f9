"""The compiled step of :class:`~taskspace.control.InverseDynamicsQP` (``_native/idqp_kernel.cpp``).

The kernel evaluates the same weighted QP as :meth:`InverseDynamicsQP.build
<taskspace.control.InverseDynamicsQP.build>` (dynamics by Pinocchio's CRBA and nonlinear
effects, contact Jacobians and drifts from the state's data, task rows, cones, normal-force
limits, torque limits, joint-limit bounds) and solves it: the equality-constrained minimizer
when it violates nothing, else a primal-dual active-set method on the same factorization
(warm-started with the previous step's active set), else proxsuite's dense solver (kept and
warm-started) refined on its active set. A step is ``SOLVED`` only with KKT residuals within
the solver options' tolerances; otherwise the caller runs the Python path on the same state.

What it serves is declared by the objects themselves, checked in one place
(:func:`unsupported`): every task's feature declares a
:class:`~taskspace.features.compiled.CompiledTerm`, every contact a
:meth:`~taskspace.constraints.Contact.compiled_kind`; weighted mode, no center-of-pressure
task, positive regularizations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._native import idqp_kernel
from taskspace.constraints.contact import Contact, compiled_kind
from taskspace.features.compiled import CompiledTerm, compiled_term
from taskspace.qp.kkt import KKTResiduals
from taskspace.qp.result import QPResult, QPStatus
from taskspace.tasks import Task

if TYPE_CHECKING:
    from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
    from taskspace.model.state import State

_TASK_KINDS = {"pose": "POSE", "position": "POSITION", "com": "COM", "posture": "POSTURE"}
_TASK_KINDS["orientation"] = "ORIENTATION"
_CONTACT_KINDS = {"contact6d": "CONTACT6D", "point": "POINT_CONTACT"}
_NO_LIMITS = np.zeros(0)
_NO_LIMITS.setflags(write=False)


def unsupported(controller: InverseDynamicsQP) -> str:
    """Why the compiled step cannot serve ``controller`` (empty when it can)."""
    opts = controller.options
    if not opts.native:
        return "InverseDynamicsOptions(native=False)"
    if idqp_kernel() is None:
        return "the compiled kernel _idqp_kernel is not available (see taskspace info)"
    if opts.hierarchical:
        return "hierarchical mode"
    if controller.pressure_tasks:
        return "center-of-pressure tasks"
    if not (opts.acceleration_regularization > 0 and opts.force_regularization > 0):
        return "a zero regularization (the kernel needs H positive definite)"
    for t in controller.tasks:
        term = compiled_term(t.feature)
        if term is None or term.kind not in _TASK_KINDS:
            return f"task '{t.name}': its feature declares no compiled term"
    for c in controller.contacts:
        if compiled_kind(c) not in _CONTACT_KINDS:
            return f"contact '{c.name}': its class declares no compiled kind"
    return ""


class NativeInverseDynamics:
    """One compiled kernel for a controller's tasks, contacts and limits (built by its setup).

    Thread safety: not thread-safe (the kernel holds the QP workspace); the controller
    serializes its calls with its lock.
    """

    def __init__(self, controller: InverseDynamicsQP) -> None:
        module = idqp_kernel()
        assert module is not None
        self.module = module
        self.model = controller.robot._model
        self.robot = controller.robot
        self.controller = controller
        self._all_tasks: list[Task] = list(controller.tasks)
        self._build()

    def _build(self) -> None:
        """The kernel for the controller's tasks of nonzero weight (all tasks if none has one).

        A task of weight 0 adds nothing to the QP (its rows are scaled by 0): the kernel leaves
        it out, so tasks kept at weight 0 while unused (a swing foot's tasks while the foot is
        a contact) cost nothing; :meth:`solve` rebuilds the kernel when a weight changes to or
        from 0.
        """
        module, model, robot, controller = self.module, self.model, self.robot, self.controller
        self._all_weights = [t.sqrt_weight for t in self._all_tasks]
        self._weighted = [bool(np.any(w)) for w in self._all_weights]
        kernel = module.InverseDynamicsKernel(model)
        self.tasks: list[Task] = [t for t, on in zip(self._all_tasks, self._weighted) if on]
        if not self.tasks:
            self.tasks = list(self._all_tasks)
        self._skipped = [t for t in self._all_tasks if t not in self.tasks]
        for t in self.tasks:
            term = compiled_term(t.feature)
            assert term is not None
            kernel.add_task(model, getattr(module, _TASK_KINDS[term.kind]), *_task_args(term))
        self.contacts: list[Contact] = list(controller.contacts)
        self._limit_contacts: list[Contact] = []
        for c in self.contacts:
            K, k, row = controller._cone(c)  # the contact's cone (with transition rows)
            kernel.add_contact(
                model,
                getattr(module, _CONTACT_KINDS[str(compiled_kind(c))]),
                c.frame_id,
                np.asarray(K, dtype=float),
                np.asarray(k, dtype=float),
                -1 if row is None else row,
            )
            if row is not None:
                self._limit_contacts.append(c)
        opts = controller.options
        solver = opts.solver
        reg = np.ascontiguousarray(np.diag(controller._reg), dtype=float)
        iq, iv = robot.limited_joints_q, robot.limited_joints_v
        if not opts.joint_limits:
            iq = iv = np.zeros(0, dtype=int)
        kernel.finalize(
            reg,
            [int(i) for i in controller.actuated],
            np.asarray(controller._effort, dtype=float),
            bool(opts.torque_limits),
            [int(i) for i in iq],
            [int(i) for i in iv],
            np.asarray(robot.lower_limits[iq], dtype=float),
            np.asarray(robot.upper_limits[iq], dtype=float),
            np.asarray(robot.velocity_limits[iv], dtype=float),
            float(opts.limits_horizon),
            float(solver.eps_abs),
            float(solver.eps_rel),
            float(solver.feasibility_tolerance),
            int(solver.max_iter),
            int(solver.max_iter_in),
        )
        self.kernel = kernel
        self.n, self.n_eq, self.n_in = int(kernel.n), int(kernel.n_eq), int(kernel.n_in)
        self.nv = robot.nv
        self._task_keys: list[tuple[Any, ...]] = []
        self._contact_keys: list[tuple[Any, Any]] = []
        self._solve = kernel.solve
        self._none_offsets: list[None] = [None] * len(self.tasks)
        self._out_size = 2 * self.n + self.nv + self.n_eq + self.n_in
        self._UNCONSTRAINED = module.UNCONSTRAINED
        self._SOLVED = module.SOLVED
        self._ACTIVE_SET = module.ACTIVE_SET

    def _send_task_gains(self) -> None:
        m = int(self.kernel.rows)
        w, kp, kd = np.ones(m), np.zeros(m), np.zeros(m)
        row = 0
        for t in self.tasks:
            rows = slice(row, row + t.dim)
            w[rows], kp[rows], kd[rows] = t.sqrt_weight, t.kp, t.kd
            row += t.dim
        self.kernel.set_task_gains(w, kp, kd)
        self._task_keys = [(t.sqrt_weight, t.kp, t.kd) for t in self.tasks]

    def _send_contact_gains(self) -> None:
        kd = np.array([float(c.kd) for c in self.contacts])
        kp = np.array([float(c.kp) for c in self.contacts])
        self.kernel.set_contact_gains(kd, kp)
        self._contact_keys = [(c.kd, c.kp) for c in self.contacts]

    def solve(self, state: State) -> tuple[QPResult, np.ndarray, float, float] | None:
        """``(qp result, tau, build time, solve time)``, or ``None``: take the Python path.

        The result's ``x``, multipliers and KKT residuals are the kernel's; its status is
        ``UNCONSTRAINED`` (the equality-constrained minimizer, backend ``compiled cholesky``) or
        ``SOLVED`` (the kernel's active-set method warm-started with the previous step's active
        set, ``compiled active set``; when that fails, proxsuite refined on its active set,
        ``compiled proxsuite``), all certified by the residuals.
        """
        # a weight reassigned to or from 0: the kernel's task set changes
        for t, w in zip(self._all_tasks, self._all_weights):
            if t.sqrt_weight is not w:
                self._reweigh()
                break
        for t in self._skipped:  # a task left out still needs its target, as on every path
            if t._target is None:
                t._require_target()
        # one pass over the tasks: reassigned weights or gains (sent again), targets, offsets
        keys = self._task_keys
        resend = not keys
        targets = []
        offsets: list[Any] | None = None
        for i, t in enumerate(self.tasks):
            if not resend:
                k = keys[i]
                if t.sqrt_weight is not k[0] or t.kp is not k[1] or t.kd is not k[2]:
                    resend = True
            target = t._target
            if target is None:
                t._require_target()  # raises, naming the task
            targets.append(target)
            rv, ra = t.reference_velocity, t.reference_acceleration
            if rv is not None or ra is not None:
                if offsets is None:
                    offsets = list(self._none_offsets)
                off = np.zeros(t.dim)
                if rv is not None:
                    off += t.kd * rv
                if ra is not None:
                    off += ra
                offsets[i] = off
        if resend:
            self._send_task_gains()
        # contacts: reassigned gains (sent again), Baumgarte references
        ckeys = self._contact_keys
        resend = not ckeys
        references: list[Any] | None = None
        for i, c in enumerate(self.contacts):
            kp = c.kp
            if not resend and (c.kd is not ckeys[i][0] or kp is not ckeys[i][1]):
                resend = True
            if kp and c.reference is not None:
                if references is None:
                    references = [None] * len(self.contacts)
                references[i] = c.reference
        if resend:
            self._send_contact_gains()
        limits = (
            np.array(
                [self.controller._normal_force_limit(c) for c in self._limit_contacts],
                dtype=float,
            )
            if self._limit_contacts
            else _NO_LIMITS
        )
        out = np.empty(self._out_size)  # (x, tau, y, z, z_box), fresh: the result keeps views
        (status, primal, dual, comp, gap, sp, sd, sg, iterations, objective, t_build, t_solve) = (
            self._solve(
                self.model,
                state._data,  # made by the state for ``state._model``, cannot be replaced
                state.q,
                state.v,
                targets,
                offsets,
                references,
                limits,
                out,
            )
        )
        if status == self._UNCONSTRAINED:
            qp_status, backend = QPStatus.UNCONSTRAINED, "compiled cholesky"
        elif status == self._ACTIVE_SET:
            qp_status, backend = QPStatus.SOLVED, "compiled active set"
        elif status == self._SOLVED:
            qp_status, backend = QPStatus.SOLVED, "compiled proxsuite"
        else:
            return None
        n, nv, n_eq, n_in = self.n, self.nv, self.n_eq, self.n_in
        head = out[: n + nv]
        with np.errstate(over="ignore", invalid="ignore"):  # (the overflow is the answer)
            size = float(head.dot(head))
        if not math.isfinite(size + primal + dual):
            # (a state beyond ~1e150, e.g. v = 1e160: the kernel's squares overflow and its
            # NaN residuals passed as certified, tau NaN): the Python path refuses the data
            return None
        x = out[:n]
        tau = out[n : n + nv]
        y = out[n + nv : n + nv + n_eq]
        z = out[n + nv + n_eq : n + nv + n_eq + n_in]
        z_box = out[n + nv + n_eq + n_in :]
        result = QPResult(
            True,
            qp_status,
            x,
            objective,
            iterations,
            t_solve,
            backend,
            kkt=KKTResiduals(primal, dual, comp, gap, sp, sd, sg),
            y=y,
            z=z,
            z_box=z_box,
        )
        return result, tau, t_build, t_solve

    def _reweigh(self) -> None:
        """Weights were reassigned: rebuild the kernel if a task's weight became or left 0."""
        weights = [t.sqrt_weight for t in self._all_tasks]
        if [bool(np.any(w)) for w in weights] != self._weighted:
            self._build()
        else:
            self._all_weights = weights

    def problem(self) -> tuple[np.ndarray, ...]:
        """The QP of the last step: ``(H, g, A, b, C, l, u, lb, ub)`` (copies)."""
        return tuple(np.asarray(a) for a in self.kernel.problem())


def _task_args(term: CompiledTerm) -> tuple[int, Sequence[int] | None]:
    return term.frame_id, None if term.rows is None else list(term.rows)
