"""The compiled inverse-dynamics step tried as a new user would (issue #15, trust).

Every answer is checked against references independent of the kernel: the Python path's QP
(``InverseDynamicsQP.build``) solved by quadprog, the KKT conditions of that QP computed with
NumPy at the kernel's point and multipliers, and Pinocchio's RNEA (see
``test_control_idqp_compiled._check_step``).
"""

from __future__ import annotations

import threading
import warnings
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import idqp_kernel
from taskspace.constraints import Contact, Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import InvalidInputError, ShapeError, TaskspaceError
from taskspace.model import Robot, State
from taskspace.tasks import Task
from tests.control.test_control_all_legged_stand import LEGGED, _standing_posture, _with_flat_soles
from tests.control.test_control_idqp_compiled import (
    _check_kkt,
    _check_step,
    _g1_standing,
    _pair,
    _quadprog,
    _random_state,
)

pytestmark = pytest.mark.skipif(idqp_kernel() is None, reason="compiled kernels not built")


def _fresh_g1() -> Robot:
    """A G1 of its own (``set_limits`` must not leak into the session's cached robot)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("g1", geometry=False)


# ---------------------------------------------------------------- derived objects / versions
def test_tasks_contacts_and_options_are_fixed_after_construction() -> None:
    """Before: ``ctrl.tasks.append(t)`` / ``ctrl.contacts.pop()`` were accepted and ignored by
    both paths (rows, buffers and the kernel were built at construction): the answer silently
    ignored the new task and still pushed on the removed foot. Now they are tuples and
    assigning them raises."""
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    for ctrl in (compiled, python):
        with pytest.raises((AttributeError, TypeError)):
            ctrl.tasks.append(tasks[0])  # type: ignore[attr-defined]
        with pytest.raises((AttributeError, TypeError)):
            ctrl.contacts.pop()  # type: ignore[attr-defined]
        for name in ("tasks", "contacts", "pressure_tasks", "options"):
            with pytest.raises(InvalidInputError, match="fixed at construction"):
                setattr(ctrl, name, [])
    # the caller's own lists are copies: changing them changes nothing
    tasks.pop()
    contacts.pop()
    assert len(compiled.tasks) == 4 and len(compiled.contacts) == 2
    state = _random_state(robot, np.random.default_rng(3))
    _check_step(compiled, python, state)


def test_task_feature_is_fixed_after_construction() -> None:
    """Before: ``task.feature = FramePose(robot, "pelvis")`` was accepted; the Python path then
    drove the pelvis while the compiled kernel (its term built at construction) still drove
    the hand: two different answers, both SOLVED. Now the assignment raises."""
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    hand = tasks[1]
    with pytest.raises(InvalidInputError, match="feature is fixed"):
        hand.feature = F.FramePose(robot, "pelvis")
    assert hand.feature.frame_id == robot.frame_id("left_rubber_hand")  # type: ignore[attr-defined]
    _check_step(compiled, python, _random_state(robot, np.random.default_rng(4)))


@pytest.mark.parametrize("which", ["effort", "unactuated", "position", "velocity"])
def test_set_limits_after_construction_are_used(which: str) -> None:
    """``Robot.set_limits`` after the first step: the compiled step answers the QP of a
    controller built after the change (quadprog), never the old limits."""
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled = InverseDynamicsQP(robot, tasks, contacts)
    state = _random_state(robot, np.random.default_rng(1))
    before = compiled.solve(state)
    assert before.compiled
    q, v = state.q, state.v
    if which == "effort":
        effort = robot.effort_limits.copy()
        effort[6:] *= 0.3
        robot.set_limits(effort=effort)
    elif which == "unactuated":  # the wrist joints lose their motors: n_eq grows
        effort = robot.effort_limits.copy()
        effort[-3:] = 0.0
        robot.set_limits(effort=effort)
    elif which == "position":
        lo, up = robot.lower_limits.copy(), robot.upper_limits.copy()
        lo[7:] = np.maximum(lo[7:], q[7:] - 0.02)
        up[7:] = np.minimum(up[7:], q[7:] + 0.02)
        robot.set_limits(lower=lo, upper=up)
        v = np.zeros(robot.nv)
    else:
        vel = robot.velocity_limits.copy()
        vel[6:] = 0.3
        robot.set_limits(velocity=vel)
        v = np.clip(v, -0.29, 0.29)
    state = robot.state(q, v)
    fresh = InverseDynamicsQP(robot, tasks, contacts, InverseDynamicsOptions(native=False))
    p = fresh.build(state)
    x_ref = _quadprog(p)
    res = compiled.solve(state)
    assert res.compiled
    np.testing.assert_allclose(res.qp.x, x_ref, atol=1e-6 * max(1.0, np.abs(x_ref).max()))
    _check_kkt(p, res.qp.x, res.qp.y, res.qp.z, res.qp.z_box)
    assert np.all(res.tau[fresh.unactuated] == 0.0)


def test_state_of_another_robot_is_refused() -> None:
    robot, other = _fresh_g1(), _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    ctrl = InverseDynamicsQP(robot, tasks, contacts)
    with pytest.raises(InvalidInputError, match="belongs to robot"):
        ctrl.solve(other.state(other.q_default, np.zeros(other.nv)))
    with pytest.raises(InvalidInputError, match="velocity"):
        ctrl.solve(robot.state(robot.q_default))


# ---------------------------------------------------------------- inputs
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e300])
def test_bad_numbers_never_give_a_solved_non_finite_torque(bad: float) -> None:
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    ctrl = InverseDynamicsQP(robot, tasks, contacts)
    state = _random_state(robot, np.random.default_rng(1))
    for i in (0, 10):
        for which in ("q", "v"):
            q, v = state.q.copy(), state.v.copy()
            (q if which == "q" else v)[i + (7 if which == "q" else 0)] = bad
            try:
                res = ctrl.solve(robot.state(q, v))
            except TaskspaceError:
                continue
            assert not res.success or np.all(np.isfinite(res.tau))
    q = state.q.copy()
    q[3:7] *= 3.0  # unnormalized quaternion
    with pytest.raises(TaskspaceError, match="unit norm"):
        ctrl.solve(robot.state(q, state.v))


def test_float32_and_int_states_match_float64() -> None:
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    state = _random_state(robot, np.random.default_rng(1))
    q32, v32 = state.q.astype(np.float32), state.v.astype(np.float32)
    _check_step(compiled, python, robot.state(q32, v32))
    _check_step(compiled, python, robot.state(robot.q_default, np.zeros(robot.nv, dtype=int)))


def test_contact_reference_is_validated() -> None:
    """Before: ``contact.reference = np.zeros(3)`` gave a bare Boost TypeError (compiled) or
    AttributeError (Python path) at the next step; a scaled "rotation" (2 I) was used by both
    paths (log6 of a non-rotation, SOLVED); ``set_reference`` with a state of another robot
    anchored the contact at that robot's frame of the same index, silently."""
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    foot = contacts[0]
    foot.kp = 10.0
    state = _random_state(robot, np.random.default_rng(2))
    good = state.frame_placement(foot.frame_id)
    bad_rotation = pin.SE3(2.0 * np.eye(3), np.zeros(3))
    nan = pin.SE3(np.eye(3), np.array([np.nan, 0.0, 0.0]))
    for value in (np.zeros(3), "floor", bad_rotation, nan):
        with pytest.raises(InvalidInputError, match="reference of contact"):
            foot.reference = value
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        solo = Robot.load("solo12", geometry=False)
    with pytest.raises(InvalidInputError, match="set_reference needs a state of that robot"):
        foot.set_reference(solo.state(solo.q_default))
    assert foot.reference is None
    foot.reference = good  # a copy is kept
    good.translation[0] += 1.0
    assert foot.reference is not None and foot.reference.translation[0] != good.translation[0]
    foot.set_reference(robot.state(robot.q_default))
    _check_step(compiled, python, state)


def test_pose_target_and_task_references_are_validated() -> None:
    """Before: ``FramePose`` accepted a ``pin.SE3`` whose "rotation" is 2 I (both paths then
    SOLVED a log6 of a non-rotation) or NaN (caught only as a non-finite QP);
    ``task.reference_velocity = np.zeros(5)`` on a 3-D task gave a bare numpy broadcast
    ValueError at the next step, a list was taken as is."""
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    compiled, python = _pair(robot, tasks, contacts)
    com, hand = tasks[0], tasks[1]
    target = hand.target.copy()
    for bad in (
        pin.SE3(2.0 * np.eye(3), target.translation),
        pin.SE3(np.eye(3), np.array([np.nan, 0.0, 0.0])),
        pin.SE3(np.diag([1.0, 1.0, -1.0]), target.translation),  # a reflection
    ):
        with pytest.raises(InvalidInputError, match="target of feature"):
            hand.set_target(bad)
    assert hand.target == target
    with pytest.raises(ShapeError):
        com.reference_velocity = np.zeros(5)
    with pytest.raises(TaskspaceError, match="reference acceleration"):
        com.reference_acceleration = [np.nan, 0.0, 0.0]
    assert com.reference_velocity is None and com.reference_acceleration is None
    com.reference_acceleration = [0.1, 0.0, -0.2]  # converted to a float vector
    assert isinstance(com.reference_acceleration, np.ndarray)
    com.set_reference([0.0, 0.05, 0.0], None)
    _check_step(compiled, python, _random_state(robot, np.random.default_rng(8)))


@pytest.mark.parametrize("horizon", [1e-300, 1e-160, 1e-7, 1e300])
def test_limits_horizon_out_of_range_is_refused(horizon: float) -> None:
    """Before: 1e-300 gave a bare ZeroDivisionError building the controller; 1e-160 (2 / T^2 = inf)
    an infinite joint-limit box, i.e. the limits silently gone, reported SOLVED."""
    with pytest.raises(InvalidInputError, match="limits_horizon"):
        InverseDynamicsOptions(limits_horizon=horizon)


# ---------------------------------------------------------------- threads
def test_one_controller_shared_by_two_threads_equals_sequential() -> None:
    robot = _fresh_g1()
    tasks, contacts = _g1_standing(robot)
    ctrl = InverseDynamicsQP(robot, tasks, contacts)
    rng = np.random.default_rng(5)
    states = [_random_state(robot, rng) for _ in range(6)]
    expected = [ctrl.solve(s).tau.copy() for s in states]
    got: dict[tuple[int, int], np.ndarray] = {}
    errors: list[BaseException] = []

    def work(k: int) -> None:
        try:
            for _ in range(10):
                for i, s in enumerate(states):
                    got[(k, i)] = ctrl.solve(s).tau.copy()
        except BaseException as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for (_, i), tau in got.items():
        # warm starts differ by call order: equal to the solver's tolerance, not bit for bit
        np.testing.assert_allclose(tau, expected[i], atol=1e-6 * max(1.0, np.abs(tau).max()))


def test_two_controllers_on_two_threads_sharing_states() -> None:
    """Two compiled controllers (own kernels) on two threads, on the same State objects (the
    kernel also writes the state's center-of-mass entries): each equals its sequential run."""
    robot = _fresh_g1()
    tasks_a, contacts_a = _g1_standing(robot)
    tasks_b, contacts_b = _g1_standing(robot)
    tasks_b[0].kp = 80.0
    ctrls = [
        InverseDynamicsQP(robot, tasks_a, contacts_a),
        InverseDynamicsQP(robot, tasks_b, contacts_b),
    ]
    rng = np.random.default_rng(6)
    states = [_random_state(robot, rng) for _ in range(5)]
    expected = [[c.solve(s).tau.copy() for s in states] for c in ctrls]
    got: list[list[np.ndarray]] = [[], []]
    errors: list[BaseException] = []

    def work(k: int) -> None:
        try:
            for _ in range(10):
                for s in states:
                    got[k].append(ctrls[k].solve(s).tau.copy())
                    s.com()  # the Python side reads the data the kernel writes
        except BaseException as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for k in range(2):
        for j, tau in enumerate(got[k]):
            ref = expected[k][j % len(states)]
            np.testing.assert_allclose(tau, ref, atol=1e-6 * max(1.0, np.abs(ref).max()))
    assert np.abs(expected[0][0] - expected[1][0]).max() > 1e-3  # the two controllers differ


# ---------------------------------------------------------------- every legged robot
def _legged_controllers(name: str) -> tuple[Robot, InverseDynamicsQP, InverseDynamicsQP]:
    legged = LEGGED[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load(name, geometry=False)
    feet = legged.feet
    if legged.flat_soles:
        robot, feet = _with_flat_soles(robot, feet)
    q0 = _standing_posture(robot, legged)
    s = robot.state(q0, np.zeros(robot.nv))
    contacts: list[Contact] = [
        PointContact(robot, f, friction=0.6)
        if legged.point
        else Contact6D(robot, f, half_length=0.05, half_width=0.03, friction=0.6)
        for f in feet
    ]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), q0, weight=1e-2, kp=10.0)
    opts = InverseDynamicsOptions()
    compiled = InverseDynamicsQP(robot, [com, posture], contacts, opts)
    python = InverseDynamicsQP(robot, [com, posture], contacts, replace(opts, native=False))
    assert compiled._native is not None, compiled.native_reason
    return robot, compiled, python


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", sorted(LEGGED))
def test_every_legged_robot_compiled_equals_python_path(name: str) -> None:
    robot, compiled, python = _legged_controllers(name)
    q0 = compiled.tasks[1].target
    rng = np.random.default_rng(7)
    states: list[State] = [robot.state(q0, np.zeros(robot.nv))]
    for _ in range(2):
        q = np.asarray(q0, dtype=float).copy()
        q[7:] += 0.02 * rng.standard_normal(robot.nq - 7)
        q = np.clip(q, robot.lower_limits, robot.upper_limits)
        states.append(robot.state(robot.normalize(q), 0.1 * rng.standard_normal(robot.nv)))
    for s in states:
        _check_legged_step(robot, compiled, python, s)


def _check_legged_step(
    robot: Robot, compiled: InverseDynamicsQP, python: InverseDynamicsQP, state: State
) -> None:
    """Compiled vs the Python path, quadprog, the KKT conditions and RNEA.

    A state whose QP is infeasible (joint-limit box against the torque limits) has no
    certified kernel answer: the compiled controller runs the Python path and says so.
    """
    ref = robot.state(state.q, state.v)
    res_py = python.solve(ref)
    res = compiled.solve(state)
    if not res_py.success:
        assert not res.success and not res.compiled and res.status == res_py.status
        return
    assert res.success and res.compiled, (res.status, compiled.native_reason)
    qp = res.qp
    assert qp is not None and qp.kkt.within(1e-9, 1e-9), qp
    p = python.build(ref)
    _check_kkt(p, qp.x, qp.y, qp.z, qp.z_box)
    x_ref = _quadprog(p)
    np.testing.assert_allclose(qp.x, x_ref, atol=1e-6 * max(1.0, np.abs(x_ref).max()))
    np.testing.assert_allclose(res.tau, res_py.tau, atol=1e-6 * max(1.0, np.abs(res_py.tau).max()))
    # M a + h - J_c^T f = S^T tau by Pinocchio's RNEA, to the certificate's primal tolerance
    rhs = pin.rnea(robot.model, robot.model.createData(), state.q, state.v, res.a).copy()
    for c in compiled.contacts:
        rhs -= c.jacobian(ref).T @ res.forces[c.frame]
    tol = 1e-8 * max(1.0, qp.kkt.primal_scale, np.abs(rhs).max())
    act = compiled.actuated
    np.testing.assert_allclose(rhs[act], res.tau[act], rtol=0, atol=tol)
    assert np.abs(rhs[compiled.unactuated]).max(initial=0.0) <= tol
