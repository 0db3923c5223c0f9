"""The compiled inverse-dynamics step against independent references.

For G1 on two feet, G1 on one foot (walking tasks, a lowered normal-force limit), Talos and
Solo-12 on point feet, at random states, the compiled step (``InverseDynamicsOptions.native``)
is compared with:

* the QP the Python path builds (``InverseDynamicsQP.build``), solved by quadprog (not
  proxsuite, which the kernel uses);
* the KKT conditions of that QP, checked here with NumPy at the kernel's point and
  multipliers (stationarity, feasibility, complementarity, multiplier signs);
* Pinocchio's RNEA: ``M a + h - J_c^T f`` equals the torques on the actuated rows and is zero
  on the floating base.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace._native import idqp_kernel
from taskspace.constraints import Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import (
    CenterOfPressureTask,
    InverseDynamicsOptions,
    InverseDynamicsQP,
)
from taskspace.model import Robot, State
from taskspace.qp.problem import QPProblem
from taskspace.qp.result import QPStatus
from taskspace.qp.solver import QPSolverOptions
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(idqp_kernel() is None, reason="compiled kernels not built")

G1_FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
G1_HANDS = ("left_rubber_hand", "right_rubber_hand")
TALOS_FEET = ("left_sole_link", "right_sole_link")
SOLO_FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
BIG = 1e19  # bounds beyond this are infinite (taskspace.qp.problem.INF = 1e20)
BINDING = ("compiled active set", "compiled proxsuite")  # backends of steps with active rows


def _pair(
    robot: Robot, tasks: list[Task], contacts: list, **options: object
) -> tuple[InverseDynamicsQP, InverseDynamicsQP]:
    """The compiled controller and the Python one (same tasks and contacts)."""
    opts = InverseDynamicsOptions(**options)  # type: ignore[arg-type]
    compiled = InverseDynamicsQP(robot, tasks, contacts, opts)
    python = InverseDynamicsQP(robot, tasks, contacts, replace(opts, native=False))
    assert compiled._native is not None, compiled.native_reason
    assert python._native is None
    return compiled, python


def _random_state(robot: Robot, rng: np.random.Generator, scale: float = 0.1) -> State:
    q = robot.q_default.copy()
    q[7:] += scale * rng.standard_normal(robot.nq - 7)
    q = np.clip(q, robot.lower_limits, robot.upper_limits)
    v = 0.5 * rng.standard_normal(robot.nv)
    return robot.state(q, v)


def _quadprog(p: QPProblem) -> np.ndarray:
    """The optimum of ``p`` by quadprog (Goldfarb-Idnani, an exact active-set method)."""
    rows, rhs = [p.A], [p.b]
    lo, hi = p.l > -BIG, p.u < BIG
    rows += [p.C[lo], -p.C[hi]]
    rhs += [p.l[lo], -p.u[hi]]
    eye = np.eye(p.n)
    blo, bhi = p.lb > -BIG, p.ub < BIG
    rows += [eye[blo], -eye[bhi]]
    rhs += [p.lb[blo], -p.ub[bhi]]
    C = np.vstack(rows)
    b = np.concatenate(rhs)
    return np.asarray(quadprog.solve_qp(p.H, -p.g, C.T, b, p.n_eq)[0])


def _check_kkt(p: QPProblem, x: np.ndarray, y: np.ndarray, z: np.ndarray, zb: np.ndarray) -> None:
    """The KKT conditions of ``p`` at ``(x, y, z, z_box)``, with NumPy (1e-9 relative)."""
    Hx = p.H @ x
    force = p.A.T @ y + p.C.T @ z + zb
    dual_scale = max(np.abs(Hx).max(), np.abs(p.g).max(), np.abs(force).max(), 1.0)
    assert np.abs(Hx + p.g + force).max() <= 1e-9 * dual_scale
    Cx = p.C @ x
    primal_scale = max(np.abs(x).max(), np.abs(p.b).max(initial=0.0), np.abs(Cx).max(), 1.0)
    tol = 1e-9 * primal_scale
    assert np.abs(p.A @ x - p.b).max(initial=0.0) <= tol
    assert np.all(Cx >= p.l - tol) and np.all(Cx <= p.u + tol)
    assert np.all(x >= p.lb - tol) and np.all(x <= p.ub + tol)
    # a multiplier pushes only against a bound the point is at (its sign says which)
    for w, val, lo, hi in ((z, Cx, p.l, p.u), (zb, x, p.lb, p.ub)):
        up, down = w > 0, w < 0
        assert np.all(np.minimum(np.abs(w[up]), np.abs(hi[up] - val[up])) <= tol)
        assert np.all(np.minimum(np.abs(w[down]), np.abs(val[down] - lo[down])) <= tol)


def _check_step(compiled: InverseDynamicsQP, python: InverseDynamicsQP, state: State) -> str:
    """One compiled step against quadprog, the KKT conditions and RNEA; returns its backend."""
    robot = compiled.robot
    res = compiled.solve(state)
    assert res.success and res.compiled, (res.status, compiled.native_reason)
    qp = res.qp
    assert qp is not None and qp.status in (QPStatus.UNCONSTRAINED, QPStatus.SOLVED)
    assert qp.kkt.within(1e-9, 1e-9), qp.kkt
    # the reference problem, built by the Python path at the same (q, v)
    ref_state = robot.state(state.q, state.v)
    p = python.build(ref_state)
    x = qp.x
    _check_kkt(p, x, qp.y, qp.z, qp.z_box)
    x_ref = _quadprog(p)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-6 * max(1.0, np.abs(x_ref).max()))
    # the Python path's own answer (the reference implementation) agrees as well
    res_py = python.solve(ref_state)
    assert not res_py.compiled
    np.testing.assert_allclose(res.a, res_py.a, atol=1e-7 * max(1.0, np.abs(res_py.a).max()))
    np.testing.assert_allclose(res.tau, res_py.tau, atol=1e-6 * max(1.0, np.abs(res_py.tau).max()))
    # rigid-body dynamics: M a + h - J_c^T f = S^T tau (Pinocchio's RNEA, not our M and h)
    data = robot.model.createData()
    rhs = pin.rnea(robot.model, data, state.q, state.v, res.a).copy()
    for c in compiled.contacts:
        rhs -= c.jacobian(ref_state).T @ res.forces[c.frame]
    scale = max(1.0, np.abs(rhs).max())
    act = compiled.actuated
    np.testing.assert_allclose(rhs[act], res.tau[act], atol=1e-8 * scale)
    assert np.abs(rhs[compiled.unactuated]).max(initial=0.0) <= 1e-8 * scale
    assert np.all(res.tau[compiled.unactuated] == 0.0)
    return qp.backend


def _g1_standing(robot: Robot) -> tuple[list[Task], list[Contact6D]]:
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in G1_FEET]
    com = Task(F.CenterOfMass(robot), kp=50.0)
    com.set_target_from_state(s)
    com.set_target(com.target + np.array([0.01, 0.02, -0.01]))
    hands = [Task(F.FramePose(robot, h), kp=50.0, weight=0.1) for h in G1_HANDS]
    for t in hands:
        t.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    return [com, *hands, posture], contacts


def test_g1_two_feet_random_states() -> None:
    robot = load_robot("g1")
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    rng = np.random.default_rng(1)
    backends = {_check_step(compiled, python, _random_state(robot, rng)) for _ in range(4)}
    # the standing state itself: the equality-constrained minimizer is the optimum
    still = robot.state(robot.q_default, np.zeros(robot.nv))
    backends.add(_check_step(compiled, python, still))
    assert "compiled cholesky" in backends


def test_g1_one_foot_walking_tasks_and_force_limit() -> None:
    """Single support with the walking controller's tasks; a lowered normal-force limit binds."""
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    weight = robot.mass * 9.81
    stance = Contact6D(robot, G1_FEET[0], half_length=0.1, half_width=0.03, max_force=10 * weight)
    com = Task(F.CenterOfMass(robot), kp=40.0)
    com.set_target_from_state(s)
    pelvis = Task(F.Orientation(robot, "pelvis"), weight=0.5, kp=20.0)
    pelvis.set_target_from_state(s)
    foot_pos = Task(F.Position(robot, G1_FEET[1]), weight=10.0, kp=100.0)
    lifted = s.frame_placement(robot.frame_id(G1_FEET[1])).translation + np.array([0, 0, 0.05])
    foot_pos.set_target(lifted)
    foot_pos.set_reference(np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, -0.5]))
    foot_rot = Task(F.Orientation(robot, G1_FEET[1]), weight=10.0, kp=100.0)
    foot_rot.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    compiled, python = _pair(robot, [com, pelvis, posture, foot_pos, foot_rot], [stance])
    rng = np.random.default_rng(2)
    for _ in range(3):
        _check_step(compiled, python, _random_state(robot, rng, 0.05))
    # lower the normal-force limit well below the weight: the row binds
    stance.set_normal_force_limit(0.5 * weight)
    state = robot.state(robot.q_default, np.zeros(robot.nv))
    assert _check_step(compiled, python, state) in BINDING
    res = compiled.solve(state)
    assert res.forces[G1_FEET[0]][2] == pytest.approx(0.5 * weight, rel=1e-9)
    stance.set_normal_force_limit(None)
    res = compiled.solve(state)
    assert res.forces[G1_FEET[0]][2] > 0.9 * weight


@pytest.mark.parametrize("active_set", [True, False])
def test_g1_force_limit_on_two_feet(active_set: bool) -> None:
    """``set_normal_force_limit`` is read at every compiled step (the walking force ramps).

    With the kernel's active-set method, and without it (proxsuite alone).
    """
    robot = load_robot("g1")
    tasks, _ = _g1_standing(robot)
    weight = robot.mass * 9.81
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03, max_force=10 * weight)
        for f in G1_FEET
    ]
    compiled, python = _pair(robot, tasks, contacts)
    assert compiled._native is not None
    compiled._native.kernel.set_active_set(active_set)
    expected = "compiled active set" if active_set else "compiled proxsuite"
    state = robot.state(robot.q_default, np.zeros(robot.nv))
    free = compiled.solve(state)
    left = free.forces[G1_FEET[0]][2]
    for limit in (0.5 * left, 0.1 * left, contacts[0].min_force):
        contacts[0].set_normal_force_limit(limit)
        assert _check_step(compiled, python, state) == expected
        res = compiled.solve(state)
        assert res.forces[G1_FEET[0]][2] == pytest.approx(limit, rel=1e-9, abs=1e-9)
        # the other foot carries the rest of the weight's share
        assert res.forces[G1_FEET[1]][2] > free.forces[G1_FEET[1]][2]
    contacts[0].set_normal_force_limit(None)
    np.testing.assert_allclose(compiled.solve(state).a, free.a, atol=1e-9)


def test_talos_two_feet() -> None:
    robot = load_robot("talos")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.05) for f in TALOS_FEET]
    com = Task(F.CenterOfMass(robot), kp=20.0)
    com.set_target_from_state(s)
    com.set_target(com.target + np.array([0.0, 0.03, 0.0]))
    torso = Task(F.Orientation(robot, "torso_2_link"), weight=0.5, kp=20.0)
    torso.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=10.0)
    compiled, python = _pair(robot, [com, torso, posture], contacts)
    rng = np.random.default_rng(3)
    for _ in range(3):
        _check_step(compiled, python, _random_state(robot, rng, 0.05))


def test_solo12_point_feet_with_contact_kp() -> None:
    robot = load_robot("solo12")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [PointContact(robot, f, friction=0.6, kp=30.0, max_force=100.0) for f in SOLO_FEET]
    for c in contacts:
        c.set_reference(s)  # Baumgarte position term: the kernel reads the reference
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    com.set_target(com.target + np.array([0.02, -0.01, 0.01]))
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=10.0)
    compiled, python = _pair(robot, [com, posture], contacts)
    rng = np.random.default_rng(4)
    backends = {_check_step(compiled, python, _random_state(robot, rng, 0.2)) for _ in range(4)}
    contacts[0].set_normal_force_limit(2.0)
    backends.add(_check_step(compiled, python, _random_state(robot, rng, 0.05)))
    assert backends & set(BINDING)


def test_what_the_kernel_serves_is_declared() -> None:
    """Contacts and features declare the compiled path; anything else runs the Python path."""
    robot = load_robot("g1")
    tasks, contacts = _g1_standing(robot)
    state = robot.state(robot.q_default, np.zeros(robot.nv))

    class Shifted(Contact6D):  # may change the Jacobian: declares nothing, not served
        pass

    shifted = [Shifted(robot, f, half_length=0.1, half_width=0.03) for f in G1_FEET]
    ctrl = InverseDynamicsQP(robot, tasks, shifted)
    assert ctrl._native is None and "contact" in ctrl.native_reason
    assert not ctrl.solve(state).compiled
    offset = Task(F.Position(robot, G1_HANDS[0], offset=[0.0, 0.0, 0.1]), kp=10.0)
    offset.set_target_from_state(state)
    ctrl = InverseDynamicsQP(robot, [*tasks, offset], contacts)
    assert ctrl._native is None and "declares no compiled term" in ctrl.native_reason
    cop = CenterOfPressureTask(contacts[0])
    ctrl = InverseDynamicsQP(robot, tasks, contacts, pressure_tasks=[cop])
    assert ctrl._native is None and "center-of-pressure" in ctrl.native_reason
    ctrl = InverseDynamicsQP(robot, tasks, contacts, InverseDynamicsOptions(hierarchical=True))
    assert ctrl._native is None
    ctrl = InverseDynamicsQP(robot, tasks, contacts)
    res = ctrl.solve(state)
    assert res.compiled and res.qp is not None and res.qp.backend.startswith("compiled")


def test_gains_reassigned_between_steps_are_sent() -> None:
    robot = load_robot("g1")
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    state = _random_state(robot, np.random.default_rng(5))
    _check_step(compiled, python, state)
    tasks[0].kp = 5.0
    tasks[0].kd = 1.0
    tasks[-1].weight = 0.5
    contacts[1].kd = 5.0
    _check_step(compiled, python, state)


def test_panda_without_contacts_torque_limits_bind() -> None:
    """A fixed base and no contacts (no equality rows): torque-limit rows in the working set."""
    robot = load_robot("panda")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    tcp = Task(F.Position(robot, "panda_hand_tcp"), kp=1e5, kd=600.0)
    tcp.set_target(s.frame_placement(robot.frame_id("panda_hand_tcp")).translation + 0.3)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3, kp=10.0)
    compiled, python = _pair(robot, [tcp, posture], [])
    rng = np.random.default_rng(6)
    backends = {_check_step(compiled, python, s)}
    for _ in range(3):
        q = np.clip(
            robot.q_default + 0.3 * rng.standard_normal(robot.nq),
            robot.lower_limits,
            robot.upper_limits,
        )
        backends.add(_check_step(compiled, python, robot.state(q, rng.standard_normal(robot.nv))))
    assert backends & set(BINDING)
    res = compiled.solve(s)
    assert np.any(np.isclose(np.abs(res.tau), robot.effort_limits, rtol=1e-9))


def test_uncertified_steps_take_the_python_path() -> None:
    """With zero tolerances no kernel answer is certified: every step runs the Python path."""
    robot = load_robot("g1")
    tasks, contacts = _g1_standing(robot)
    strict = QPSolverOptions(
        backend="daqp",
        fallbacks=(),
        eps_abs=0.0,
        eps_rel=0.0,
        max_iter=1,
        max_iter_in=1,
        max_polish_iter=1,
        relax_on_failure=False,
    )
    ctrl = InverseDynamicsQP(robot, tasks, contacts, InverseDynamicsOptions(solver=strict))
    assert ctrl._native is not None
    res = ctrl.solve(_random_state(robot, np.random.default_rng(7)))
    assert not res.compiled
    assert res.qp is not None and not res.qp.backend.startswith("compiled")


def test_reset_forgets_warm_starts() -> None:
    # A step whose solve depends on the previous step's active set (a lowered force limit
    # binds): after reset() the same states give a fresh controller's results bit for bit.
    robot = load_robot("g1")
    tasks, _ = _g1_standing(robot)
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03, max_force=1000.0) for f in G1_FEET
    ]
    contacts[0].set_normal_force_limit(40.0)
    try:
        rng = np.random.default_rng(5)
        states = [_random_state(robot, rng) for _ in range(6)]
        fresh = InverseDynamicsQP(robot, tasks, contacts)
        first = [fresh.solve(s).tau.copy() for s in states]
        used = InverseDynamicsQP(robot, tasks, contacts)
        for s in reversed(states):  # other warm starts
            used.solve(s)
        used.reset()
        again = [used.solve(s).tau.copy() for s in states]
        for a, b in zip(first, again):
            np.testing.assert_array_equal(a, b)
    finally:
        contacts[0].set_normal_force_limit(None)
