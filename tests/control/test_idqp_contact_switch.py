"""Contacts added and removed at run time on one InverseDynamicsQP (issue #16, item 5).

References, all independent of the controller's own paths:

* Pinocchio's RNEA: ``M a + h - J_c^T f`` with the *active* contacts only (Jacobians from
  ``pin.getFrameJacobian``) equals the torques on the actuated rows and is zero on the
  floating base;
* the contacts' friction cones ``K f >= k`` (``Contact.cone``) and the ramp's bound, checked
  here with NumPy;
* the KKT residuals of every ``SOLVED`` step (``QPResult.kkt``);
* a rollout with Pinocchio's constraint dynamics (``simulate_with_contacts``): the simulated
  force of a released foot reaches ~0 before it is lifted, and G1 stands on the other foot.

Continuity bound of a removal over ``N`` steps from ``f_0``: the released foot's normal force
never exceeds ``f_0 (1 - k / N)`` at step ``k`` and falls by at most ``f_0 / N`` (+1e-6 N) per
step; it is ``0`` at step ``N``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import (
    InverseDynamicsOptions,
    InverseDynamicsQP,
    InverseDynamicsResult,
    InverseDynamicsStatus,
)
from taskspace.control.inverse_dynamics_qp_rollout import simulate_with_contacts
from taskspace.errors import TaskspaceError
from taskspace.model import Robot, State
from taskspace.qp.result import QPStatus
from taskspace.tasks import Task
from tests.conftest import load_robot

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")


def _scene(native: bool = True, hierarchical: bool = False, max_force: float | None = None):  # type: ignore[no-untyped-def]
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03, max_force=max_force) for f in FEET
    ]
    com = Task(F.CenterOfMass(robot), kp=40.0, priority=0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=1)
    opts = InverseDynamicsOptions(native=native, hierarchical=hierarchical)
    qp = InverseDynamicsQP(robot, [com, posture], contacts, opts)
    return robot, s, contacts, qp, [com, posture]


def _check_physics(robot: Robot, s: State, res: InverseDynamicsResult, contacts: dict) -> None:
    """RNEA with the active contacts, friction cones, KKT of every solved QP."""
    assert res.status is InverseDynamicsStatus.SOLVED, res.status
    assert set(res.forces) == set(res.contacts)
    model, data = robot.model, robot.model.createData()
    rhs = pin.rnea(model, data, s.q, s.v, res.a)
    pin.computeJointJacobians(model, data, s.q)
    pin.updateFramePlacements(model, data)
    for frame in res.contacts:
        J = pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL)
        rhs -= J.T @ res.forces[frame]
        K, k = contacts[frame].cone()
        f = res.forces[frame]
        bound = res.releasing.get(frame)
        if bound is None:
            assert np.all(K @ f >= k - 1e-6), (frame, (K @ f - k).min())
        else:  # released: friction and CoP rows hold, minimum force 0, normal force <= bound
            rows = ~np.all(K == np.eye(6)[2], axis=1)
            if contacts[frame].max_force_row is not None:
                rows[contacts[frame].max_force_row] = False
            assert np.all(K[rows] @ f >= k[rows] - 1e-6)
            assert -1e-6 <= f[2] <= bound + 1e-6
    assert np.abs(rhs - res.tau).max() < 1e-6 * max(1.0, np.abs(res.tau).max())
    assert np.abs(res.tau[:6]).max() < 1e-9 and np.abs(rhs[:6]).max() < 1e-6
    qps = res.level_results if res.level_results else [res.qp]
    for qp in qps:  # every SOLVED QP (closed-form UNCONSTRAINED levels are not certified)
        assert qp is not None
        if qp.status is QPStatus.SOLVED:
            assert qp.kkt.within(1e-9, 1e-6), qp.kkt


@pytest.mark.parametrize(("native", "hierarchical"), [(True, False), (False, False), (False, True)])
def test_removal_ramps_the_normal_force_to_zero(native: bool, hierarchical: bool) -> None:
    robot, s, contacts, qp, _ = _scene(native, hierarchical)
    by_frame = {c.frame: c for c in contacts}
    first = qp.solve(s)
    _check_physics(robot, s, first, by_frame)
    f0 = first.forces[FEET[0]][2]
    assert f0 > 100.0
    n_steps, version = 10, qp.contacts_version
    qp.remove_contact(FEET[0], transition_time=0.1, dt=0.01)
    assert qp.contacts_version == version + 1
    previous = f0
    for k in range(1, n_steps + 1):
        res = qp.solve(s)
        assert res.contacts == FEET
        bound = f0 * (1.0 - k / n_steps)
        assert res.releasing[FEET[0]] == pytest.approx(bound, abs=1e-9)
        fz = res.forces[FEET[0]][2]
        assert fz <= bound + 1e-6
        assert previous - fz <= f0 / n_steps + 1e-6  # no jump down beyond the ramp's rate
        assert fz <= previous + 1e-6  # never up
        _check_physics(robot, s, res, by_frame)
        if native:
            assert res.compiled
        previous = fz
    assert abs(previous) < 1e-6
    res = qp.solve(s)  # the transition is over: the contact is gone
    assert res.contacts == (FEET[1],) and not res.releasing
    assert qp.contacts == (contacts[1],) and qp.n == robot.nv + 6
    _check_physics(robot, s, res, by_frame)
    assert res.compiled is native and not (native and hierarchical)


@pytest.mark.parametrize("native", [True, False])
def test_add_and_instant_removal_rebuild_the_qp(native: bool) -> None:
    robot, s, contacts, qp, tasks = _scene(native)
    by_frame = {c.frame: c for c in contacts}
    qp.remove_contact(FEET[1])
    res = qp.solve(s)
    assert res.contacts == (FEET[0],) and qp.n == robot.nv + 6
    _check_physics(robot, s, res, by_frame)
    # the same QP as a controller built with one foot (its workspace was rebuilt)
    single = InverseDynamicsQP(robot, tasks, [contacts[0]], qp.options)
    ref = single.solve(s)
    np.testing.assert_allclose(res.a, ref.a, atol=1e-7)
    qp.add_contact(contacts[1])
    assert qp.contacts_version == 2 and qp.n == robot.nv + 12
    res = qp.solve(s)
    assert res.contacts == FEET and res.compiled is native
    _check_physics(robot, s, res, by_frame)
    # both feet carry the weight again
    total = sum(res.forces[f][2] for f in FEET)
    assert total == pytest.approx(robot.mass * 9.81, rel=0.05)


def test_removal_respects_a_lowered_maximum_and_max_normal_force_setter() -> None:
    robot, s, contacts, qp, _ = _scene(max_force=1000.0)
    left = contacts[0]
    left.max_normal_force = 80.0
    assert left.normal_force_limit == 80.0 == left.max_normal_force
    res = qp.solve(s)
    assert res.forces[FEET[0]][2] == pytest.approx(80.0, abs=1e-6)
    qp.remove_contact(FEET[0], transition_time=0.04, dt=0.01)
    bounds = [qp.solve(s).releasing[FEET[0]] for _ in range(4)]
    np.testing.assert_allclose(bounds, [60.0, 40.0, 20.0, 0.0], atol=1e-6)
    for bad in (float("nan"), -1.0, 1001.0, "x", np.inf):
        with pytest.raises(TaskspaceError, match="normal-force limit"):
            left.max_normal_force = bad  # type: ignore[assignment]
    left.max_normal_force = None
    assert left.max_normal_force == 1000.0
    free = Contact6D(robot, FEET[0])
    with pytest.raises(TaskspaceError, match="max_force"):
        free.max_normal_force = 10.0


def test_errors_name_what_is_valid() -> None:
    robot, _s, contacts, qp, _ = _scene()
    with pytest.raises(TaskspaceError, match="right_ankle_roll_link"):
        qp.remove_contact("pelvis")
    with pytest.raises(TaskspaceError, match="already active"):
        qp.add_contact(Contact6D(robot, FEET[0]))
    with pytest.raises(TaskspaceError, match="needs dt"):
        qp.remove_contact(FEET[0], transition_time=0.1)
    for bad in (-0.1, float("nan")):
        with pytest.raises(TaskspaceError, match="transition_time"):
            qp.remove_contact(FEET[0], transition_time=bad, dt=0.01)
    with pytest.raises(TaskspaceError, match="dt"):
        qp.remove_contact(FEET[0], transition_time=0.1, dt=0.0)
    with pytest.raises(TaskspaceError, match="another robot"):
        qp.add_contact(Contact6D(load_robot("talos"), "left_sole_link"))
    with pytest.raises(TaskspaceError, match="Contact"):
        qp.add_contact("left_ankle_roll_link")  # type: ignore[arg-type]
    with pytest.raises(TaskspaceError, match="add_contact"):
        qp.contacts = ()
    qp.remove_contact(FEET[0], transition_time=0.1, dt=0.01)
    with pytest.raises(TaskspaceError, match="already being removed"):
        qp.remove_contact(FEET[0], transition_time=0.1, dt=0.01)
    assert qp.contacts == tuple(contacts)  # the failed calls changed nothing


def test_g1_shifts_its_weight_and_lifts_a_foot_with_one_controller() -> None:
    """Rollout by Pinocchio's constraint dynamics; one controller for the three phases."""
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=60.0, kd=2.0 * np.sqrt(60.0))
    com.set_target_from_state(s)
    right = s.frame_placement(robot.frame_id(FEET[1])).translation
    target = com.target.copy()
    target[:2] = 0.2 * target[:2] + 0.8 * right[:2]  # over the right sole
    com.set_target(target)
    foot = robot.frame_id(FEET[0])
    lift = Task(F.Position(robot, FEET[0]), weight=1e-6, kp=100.0, kd=20.0)
    lift.set_target(s.frame_placement(foot).translation)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    qp = InverseDynamicsQP(robot, [com, posture, lift], contacts)
    dt = 0.002

    def control(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        res = qp.solve(robot.state(q, v))
        assert res.status is InverseDynamicsStatus.SOLVED
        return res.tau

    # 1. double support: the CoM moves over the right foot
    a = simulate_with_contacts(robot, control, s.q, s.v, 0.5, dt, list(contacts))
    assert a.inside_cones
    # 2. the left foot is unloaded over 0.1 s (both feet still held by the simulator)
    qp.remove_contact(FEET[0], transition_time=0.1, dt=dt)
    b = simulate_with_contacts(robot, control, a.q[-1], a.v[-1], 0.1, dt, list(contacts))
    # the simulator's forces (constraint dynamics, not the QP's): the ramp's 50 steps, then
    # one step where the controller has dropped the contact (the simulator still holds it)
    steps = 50
    left_fz = b.forces[FEET[0]][:, 2]
    f0 = left_fz[0] / (1.0 - 1.0 / steps)
    bounds = f0 * (1.0 - np.arange(1, steps + 1) / steps)
    assert f0 > 20.0
    assert np.all(left_fz[:steps] <= bounds + 1e-3)
    assert abs(left_fz[steps - 1]) < 1e-3  # unloaded before the lift
    assert np.all(np.abs(np.diff(left_fz[:steps])) <= f0 / steps + 1e-3)  # no jump
    assert qp.contacts == (contacts[1],)  # the step after the ramp has one contact
    # 3. single support on the same controller: the released foot rises by 3 cm
    p0 = robot.state(b.q[-1]).frame_placement(foot).translation.copy()
    lift.weight = 10.0
    lift.set_target(p0 + np.array([0.0, 0.0, 0.03]))
    c = simulate_with_contacts(robot, control, b.q[-1], b.v[-1], 0.4, dt, [contacts[1]])
    assert c.inside_cones
    p1 = robot.state(c.q[-1]).frame_placement(foot).translation
    assert p1[2] - p0[2] > 0.02
    assert abs(a.com[0, 2] - c.com[-1, 2]) < 0.02  # standing on one foot, not falling
    fz_right = c.forces[FEET[1]][:, 2]
    assert fz_right.min() > 0.7 * robot.mass * 9.81  # the weight on the right foot


def test_copy_of_options_keeps_switching() -> None:
    """A controller made with ``replace``d options switches the same way (no hidden state)."""
    robot, s, contacts, qp, tasks = _scene()
    other = InverseDynamicsQP(robot, tasks, contacts, replace(qp.options, native=False))
    for c in (qp, other):
        c.remove_contact(FEET[1])
        c.add_contact(contacts[1])
    np.testing.assert_allclose(qp.solve(s).a, other.solve(s).a, atol=1e-6)
