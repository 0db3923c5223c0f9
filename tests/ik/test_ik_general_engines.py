"""The compiled general step's engines along sequences: warm starts never change the answer.

Both engines (the active-set method warm-started with the previous step's active set, and
proxsuite's dense solver with its workspace kept and warm-started) are run along sequences
whose active sets change, whose QP sizes change and with infeasible steps in the middle. The
reference is independent of the kernel: the Python path's QP (``DifferentialIK.build``)
solved by quadprog, and that QP's KKT conditions (:func:`taskspace.qp.kkt.kkt_residuals`)
at the kernel's step and multipliers. Every feasible step must be answered by the kernel
(not declined: a wrong warm start caught by the kernel's own certificate would decline).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import (
    Constraint,
    FeatureBounds,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.errors import InvalidInputError
from taskspace.features.rows import INF, InequalityRows
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.qp.kkt import kkt_residuals
from taskspace.tasks import Task
from tests.ik.test_ik_compiled_general import HalfSpaces, quadprog_step

pytestmark = pytest.mark.skipif(
    ik_kernel() is None or not hasattr(ik_kernel(), "GENERAL_ENGINES"),
    reason="compiled IK kernel with the general step's engines not built",
)

ENGINES = tuple(ik_kernel().GENERAL_ENGINES) if ik_kernel() is not None else ()
STEP_TOL = 1e-8  # |dq - quadprog| [rad]
KKT_TOL = 1e-9


def _engines(robot: Robot, tasks, constraints, equality):  # type: ignore[no-untyped-def]
    """One solver per engine (each keeps its own warm start) and the Python path."""
    solvers = {
        e: DifferentialIK(
            robot, tasks, constraints, equality, DifferentialIKOptions(native_general_engine=e)
        )
        for e in ENGINES
    }
    for e, ik in solvers.items():
        assert ik.native and ik._native is not None and ik._native.general_engine == e
    python = DifferentialIK(
        robot, tasks, constraints, equality, options=DifferentialIKOptions(native=False)
    )
    return solvers, python


def _check(solvers, python, state, dt: float) -> tuple[np.ndarray, int]:  # type: ignore[no-untyped-def]
    """Every engine's step at ``state``: quadprog's optimum, KKT certificate; (step, actives)."""
    p = python.build(state, dt)
    reference = quadprog_step(p)
    active = 0
    for engine, ik in solvers.items():
        r = ik.solve(state, dt)
        assert r.native_declined == "", (engine, r.native_declined)
        assert r.qp.backend == "native general" and r.success
        np.testing.assert_allclose(r.dq, reference, atol=STEP_TOL, rtol=0, err_msg=engine)
        k = kkt_residuals(p, r.dq, r.qp.y, r.qp.z, r.qp.z_box)
        assert k.within(KKT_TOL, KKT_TOL), (engine, k)
        active = int(np.count_nonzero(r.qp.z) + np.count_nonzero(r.qp.z_box))
    return reference, active


def _panda_sequence(panda: Robot):  # type: ignore[no-untyped-def]
    """Tcp position to moving targets, orientation held by an equality task, posture, limits,
    two joint-space half-spaces and a CoM bound that the motion pushes in and out."""
    state = panda.state(panda.q_default)
    tcp = panda.end_effectors[0]
    position = Task(F.Position(panda, tcp))
    p0 = position.feature.value(state).copy()
    orientation = Task(F.Orientation(panda, tcp))
    orientation.set_target_from_state(state)
    posture = Task(F.JointConfiguration(panda), panda.q_default, weight=1e-3)
    A = np.array([[0, 1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, -1, 0]], dtype=float)
    com = F.CenterOfMass(panda)
    c0 = com.value(state)
    constraints = [
        JointPositionLimits(panda),
        JointVelocityLimits(panda),
        HalfSpaces(panda, A, A @ panda.q_default + np.array([0.05, 0.2])),
        FeatureBounds(com, c0 - np.array([1.0, 0.01, 1.0]), c0 + np.array([0.004, 1.0, 1.0])),
    ]
    return state, position, p0, [position, posture], constraints, [orientation]


def test_panda_sequence_both_engines_match_quadprog_while_the_active_set_changes(
    panda: Robot,
) -> None:
    """60 steps along a circle: rows and box enter and leave the active set; every step of
    every engine is quadprog's optimum; the active-set engine's warm start was both right
    (kept) and wrong (the cold solve ran); proxsuite kept its workspace."""
    state, position, p0, tasks, constraints, equality = _panda_sequence(panda)
    solvers, python = _engines(panda, tasks, constraints, equality)
    q = state.q.copy()
    actives = []
    for k in range(60):
        angle = 0.15 * k
        position.set_target(p0 + 0.25 * np.array([np.sin(angle), np.cos(angle) - 1.0, 0.3]))
        state.update(q)
        dq, active = _check(solvers, python, state, 0.05)
        actives.append(active)
        q = pin.integrate(panda.model, q, dq)
    assert len(set(actives)) >= 3  # the active set changed along the sequence
    hits, misses, _ = solvers["active_set"]._native._general.warm_stats()  # type: ignore[union-attr]
    assert hits >= 10 and misses >= 3, (hits, misses)
    if "proxsuite" in solvers:
        _, _, fresh = solvers["proxsuite"]._native._general.warm_stats()  # type: ignore[union-attr]
        assert fresh <= 3  # one workspace kept (a failed warm run may rebuild it)


class VaryingRows(Constraint):
    """A user's rows whose count changes from step to step (1, 2 or 3 rows): the QP's size
    changes, proxsuite needs one workspace per size."""

    def __init__(self, robot: Robot) -> None:
        super().__init__(robot, "varying rows")
        self.count = 1

    def inequalities(self, state, dt: float) -> InequalityRows:  # type: ignore[no-untyped-def]
        C = np.eye(self.robot.nv)[[0, 2, 4][: self.count]]
        return InequalityRows(C, np.full(self.count, -0.01), np.full(self.count, INF))


def test_changing_sizes_and_infeasible_steps_in_a_sequence(panda: Robot) -> None:
    """Sizes 1, 2, 3 rows in turn, and an unreachable equality step every 7th step: those
    decline with the reason (the Python path answers, relaxed, with culprits), the steps
    after them are quadprog's optimum again (no stale warm start survives a decline)."""
    state = panda.state(panda.q_default)
    tcp = F.Position(panda, panda.end_effectors[0])
    p0 = tcp.value(state).copy()
    reach = Task(tcp, p0, name="reach")
    tasks = [Task(F.JointConfiguration(panda), panda.q_default, weight=1e-2)]
    rows = VaryingRows(panda)
    constraints = [JointVelocityLimits(panda), rows]
    solvers, python = _engines(panda, tasks, constraints, [reach])
    q = state.q.copy()
    declined = 0
    for k in range(24):
        rows.count = 1 + k % 3
        far = k % 7 == 6
        offset = np.array([0.6, 0.0, 0.0]) if far else np.array([-0.02, 0.006 * np.sin(k), 0.006])
        reach.set_target(tcp.value(state) + offset)
        state.update(q)
        if far:
            for engine, ik in solvers.items():
                r = ik.solve(state, 0.01)
                assert r.native_declined != "" and r.qp.backend != "native general", engine
                assert not r.success and r.culprits
            declined += 1
            continue
        dq, _ = _check(solvers, python, state, 0.05)
        q = pin.integrate(panda.model, q, dq)
    assert declined == 3
    if "proxsuite" in solvers:
        _, _, fresh = solvers["proxsuite"]._native._general.warm_stats()  # type: ignore[union-attr]
        assert fresh < 12  # one workspace per size kept (rebuilt only after a failed run)


def test_g1_sequence_feet_as_equalities_com_box_active(g1: Robot) -> None:
    """G1: hands weighted and moving, feet held by equality tasks, the CoM's box edge 2 mm
    ahead of the CoM (active): 8 steps of both engines are quadprog's optimum."""
    state = g1.state(g1.q_default)
    hands = [Task(F.FramePose(g1, h)) for h in ("left_rubber_hand", "right_rubber_hand")]
    feet = [Task(F.FramePose(g1, f)) for f in ("left_ankle_roll_link", "right_ankle_roll_link")]
    for t in (*hands, *feet):
        t.set_target_from_state(state)
    start = [h.target.copy() for h in hands]
    c0 = state.com()
    box = FeatureBounds(
        F.CenterOfMass(g1), c0 - np.array([0.05, 0.05, INF]), c0 + np.array([0.002, 0.05, INF])
    )
    tasks = [*hands, Task(F.JointConfiguration(g1), g1.q_default, weight=1e-3)]
    constraints = [JointPositionLimits(g1), JointVelocityLimits(g1), box]
    solvers, python = _engines(g1, tasks, constraints, feet)
    q = state.q.copy()
    active = 0
    for k in range(8):
        for h, T0 in zip(hands, start):
            T = T0.copy()
            T.translation = T0.translation + np.array([0.02 * (k + 1), 0.0, 0.01 * k])
            h.set_target(T)
        state.update(q)
        dq, n_active = _check(solvers, python, state, 0.05)
        active += n_active > 0
        q = pin.integrate(g1.model, q, dq)
    assert active >= 4
    hits, _, _ = solvers["active_set"]._native._general.warm_stats()  # type: ignore[union-attr]
    assert hits >= 3


def test_orientation_as_a_weighted_task_on_the_compiled_path(panda: Robot) -> None:
    """A weighted Orientation task runs on the kernel (box-only path, and the general step
    with a user's row): quadprog's optimum of the Python path's QP along 10 steps."""
    state = panda.state(panda.q_default)
    tcp = panda.end_effectors[0]
    orientation = Task(F.Orientation(panda, tcp), weight=0.5)
    R0 = orientation.feature.value(state).copy()
    position = Task(F.Position(panda, tcp))
    position.set_target_from_state(state)
    tasks = [orientation, position, Task(F.JointConfiguration(panda), panda.q_default, weight=1e-3)]
    limits = [JointPositionLimits(panda), JointVelocityLimits(panda)]
    A = np.eye(1, panda.nv, 5)
    for constraints, backend in (
        (limits, "native"),
        ([*limits, HalfSpaces(panda, A, A @ state.q + 0.003)], "native general"),
    ):
        native = DifferentialIK(panda, tasks, constraints)
        python = DifferentialIK(
            panda, tasks, constraints, options=DifferentialIKOptions(native=False)
        )
        assert native.native
        q = panda.q_default.copy()
        for k in range(10):
            orientation.set_target(R0 @ pin.exp3(np.array([0.1, -0.05, 0.08]) * (k + 1)))
            state.update(q)
            r = native.solve(state, 0.05)
            assert r.qp.backend == backend, r.native_declined
            np.testing.assert_allclose(
                r.dq, quadprog_step(python.build(state, 0.05)), atol=STEP_TOL, rtol=0
            )
            q = pin.integrate(panda.model, q, r.dq)
        assert np.linalg.norm(orientation.error(state)) > 0.01  # the target moved away
        # the fused step (the armed lean step on the box-only stack) moves the state so
        moved = panda.state(q)
        step = native.solve(moved, 0.05).dq
        native.advance(moved, 0.05)
        np.testing.assert_allclose(moved.q, pin.integrate(panda.model, q, step), atol=1e-12)


def test_unknown_engine_is_refused_with_the_valid_names() -> None:
    with pytest.raises(InvalidInputError, match="active_set"):
        DifferentialIKOptions(native_general_engine="osqp")


def test_orientation_equality_with_a_weight_is_the_exact_constraint(panda: Robot) -> None:
    """An equality Orientation task with weight 4 (the kernel evaluates it): the step holds
    ``J dq = -gain e`` (the weight scales both sides), quadprog's optimum."""
    state = panda.state(panda.q_default)
    tcp = panda.end_effectors[0]
    orientation = Task(F.Orientation(panda, tcp), weight=4.0, gain=0.5)
    orientation.set_target(orientation.feature.value(state) @ pin.exp3(np.array([0.05, 0, 0])))
    position = Task(F.Position(panda, tcp))
    position.set_target(position.feature.value(state) + np.array([0.05, 0.0, 0.0]))
    tasks = [position, Task(F.JointConfiguration(panda), panda.q_default, weight=1e-3)]
    limits = [JointPositionLimits(panda), JointVelocityLimits(panda)]
    native = DifferentialIK(panda, tasks, limits, [orientation])
    python = DifferentialIK(
        panda, tasks, limits, [orientation], DifferentialIKOptions(native=False)
    )
    r = native.solve(state, 0.05)
    assert r.qp.backend == "native general", r.native_declined
    np.testing.assert_allclose(r.dq, quadprog_step(python.build(state, 0.05)), atol=STEP_TOL)
    e, J = orientation.feature.residual_and_jacobian(state, orientation.target)
    np.testing.assert_allclose(J @ r.dq, -0.5 * e, atol=1e-9)
