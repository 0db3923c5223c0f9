"""Inverse-dynamics guard rails: a fast, solved relaxation; rollouts that stop when they
diverge; a controller that follows ``Robot.set_limits``.

References: quadprog on the penalty formulation written out in the test, Pinocchio's ABA for
the rollout's dynamics, the new limits themselves for the controller.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import (
    InverseDynamicsOptions,
    InverseDynamicsQP,
    InverseDynamicsStatus,
)
from taskspace.control.inverse_dynamics_qp_rollout import (
    SimulationDivergedError,
    simulate_with_contacts,
)
from taskspace.model import Robot
from taskspace.model.state import State
from taskspace.qp import QPStatus
from taskspace.tasks import Task
from tests.qp.test_qp_no_hang import _penalty_reference


def _fresh(name: str) -> Robot:
    """A robot of our own (set_limits must not leak into the session's cached robots)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load(name, geometry=False)


def flat_footed_humanoid(
    robot: Robot, options: InverseDynamicsOptions | None = None
) -> tuple[InverseDynamicsQP, State, list[Contact6D]]:
    """simple_humanoid on flat feet, its ankle pitch cancelling hip and knee: the ankles are
    0.25-0.42 rad outside their range, so the joint-limit bounds conflict with the contacts.
    Returns the controller (CoM and posture tasks, both feet in contact), the state, the contacts.
    """
    q = robot.q_default.copy()
    for side in ("L", "R"):
        pitch = {
            j: robot.model.joints[robot.joint_id(f"{side}LEG_{j}")].idx_q
            for j in ("HIP_P", "KNEE", "ANKLE_P")
        }
        q[pitch["ANKLE_P"]] = -(q[pitch["HIP_P"]] + q[pitch["KNEE"]])
    s = robot.state(q, np.zeros(robot.nv))
    contacts = [
        Contact6D(robot, f"{side}_ankle", half_length=0.05, half_width=0.03, friction=0.6)
        for side in ("l", "r")
    ]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), q, weight=1e-2, kp=10.0)
    return InverseDynamicsQP(robot, [com, posture], contacts, options=options), s, contacts


def test_infeasible_humanoid_step_is_relaxed_quickly_to_the_penalty_optimum() -> None:
    # simple_humanoid standing on flat feet: its ankles are 0.25-0.42 rad outside their
    # range, so the joint-limit bounds conflict with the contacts. The first solve took
    # 2049-2331 proxsuite iterations and 2.7-32 s (its relaxation's Hessian was
    # 1e14-conditioned); it is now daqp on the scaled relaxation, ~200 iterations.
    robot = _fresh("simple_humanoid")
    ctrl, s, contacts = flat_footed_humanoid(robot)
    for side in ("L", "R"):
        ankle = robot.model.joints[robot.joint_id(f"{side}LEG_ANKLE_P")].idx_q
        assert s.q[ankle] < robot.lower_limits[ankle] - 0.2
    res = ctrl.solve(s)
    assert res.status is InverseDynamicsStatus.RELAXED and not res.success
    assert res.qp is not None and res.qp.status is QPStatus.RELAXED
    assert "joint limits" in res.culprits
    assert res.qp.iterations < 1000  # bounded work (no timed assertion)
    problem = ctrl.build(s)
    x_ref = _penalty_reference(problem, ctrl.options.solver.relaxation_weight)
    x = np.concatenate([res.a, *[res.forces[c.frame] for c in contacts]])
    np.testing.assert_allclose(x, x_ref, atol=1e-6 * max(1.0, np.abs(x_ref).max()))


def _runaway(gain: float):  # type: ignore[no-untyped-def]
    """Positive velocity feedback: the state grows like exp(gain t / inertia)."""
    return lambda t, q, v: gain * v + 1.0


def test_diverging_rollout_raises_with_time_step_and_quantity() -> None:
    robot = _fresh("double_pendulum")
    q0 = np.array([0.3, -0.2])
    with pytest.raises(SimulationDivergedError) as info:
        simulate_with_contacts(robot, _runaway(50.0), q0, np.zeros(2), 5.0, 1e-3, [])
    err = info.value
    assert err.quantity == "v" and err.value > err.bound == 1e3
    assert 0 < err.step < 5000 and err.time == pytest.approx(err.step * 1e-3)
    roll = err.record
    assert roll.t.shape[0] == err.step  # every sample before the diverged one, all finite
    assert np.all(np.isfinite(roll.q)) and np.all(np.isfinite(roll.v))
    assert np.abs(roll.v[-1]).max() <= 1e3
    # the record is the true dynamics up to there: Pinocchio's ABA, semi-implicit Euler
    q, v = q0.copy(), np.zeros(2)
    data = robot.model.createData()
    for k in range(min(50, err.step - 1)):
        np.testing.assert_allclose(roll.q[k], q, atol=1e-9)
        a = pin.aba(robot.model, data, q, v, 50.0 * v + 1.0)
        v = v + 1e-3 * a
        q = pin.integrate(robot.model, q, v * 1e-3)


def test_diverging_rollout_without_velocity_bound_stops_at_the_first_non_finite_state() -> None:
    robot = _fresh("double_pendulum")
    with np.errstate(all="ignore"), pytest.raises(SimulationDivergedError) as info:
        simulate_with_contacts(
            robot, _runaway(1e4), np.zeros(2), np.zeros(2), 10.0, 1e-2, [], max_velocity=np.inf
        )
    err = info.value
    assert err.quantity in ("v", "q", "a")
    assert not np.isfinite(err.value)
    assert "not finite" in str(err) and f"step {err.step}" in str(err)
    assert np.all(np.isfinite(err.record.q)) and np.all(np.isfinite(err.record.v))


def test_rollout_refuses_a_record_larger_than_memory() -> None:
    from taskspace.errors import InvalidInputError

    robot = _fresh("double_pendulum")
    with pytest.raises(InvalidInputError, match=r"simulate_with_contacts.*would record"):
        simulate_with_contacts(robot, _runaway(0.0), np.zeros(2), np.zeros(2), 1e9, 1e-3, [])


@pytest.mark.parametrize("hierarchical", [False, True])
def test_controller_follows_set_limits(hierarchical: bool) -> None:
    robot = _fresh("ur5")
    q = robot.q_default.copy()
    s = robot.state(q, np.zeros(robot.nv))
    target = q + 0.5
    posture = Task(F.JointConfiguration(robot), target, kp=400.0)
    ctrl = InverseDynamicsQP(
        robot, [posture], options=InverseDynamicsOptions(hierarchical=hierarchical)
    )
    before = ctrl.solve(s)
    assert before.success
    big = np.abs(before.tau)
    # narrower effort limits than the torques the controller asked for
    effort = np.maximum(0.25 * big, 1e-3)
    robot.set_limits(effort=effort)
    after = ctrl.solve(s)
    assert after.success
    assert np.all(np.abs(after.tau) <= effort * (1 + 1e-9) + 1e-9), (after.tau, effort)
    # narrower position limits: the shoulder at its new upper limit may not accelerate up
    lower, upper = robot.lower_limits.copy(), robot.upper_limits.copy()
    upper[1] = q[1]
    robot.set_limits(lower=lower, upper=upper)
    res = ctrl.solve(s)
    assert res.success
    # at the limit with v = 0 the bound is a <= 2 (upper - q) / T^2 = 0
    assert res.a[1] <= 1e-9
    assert before.a[1] > 1.0  # it did accelerate toward the target before
