"""Whole-body walking with one inverse-dynamics controller whose contacts change at run time.

G1 walks two steps (Pinocchio's constraint dynamics, rigid 6-D contacts switched at lift-off
and touchdown) with a single :class:`InverseDynamicsQP`: ``remove_contact`` with a transition
before each lift-off, ``add_contact`` at each touchdown. References, independent of the
controller's paths:

* Pinocchio's RNEA: at every solve ``rnea(q, v, a) - sum J_c^T f`` over the contacts the
  controller reports active (``pin.getFrameJacobian``, LOCAL) equals the torque on the
  actuated rows and is zero on the floating base;
* the contacts the simulator holds at that sample (a foot is simulated as a contact exactly
  when the controller has it);
* the contacts' friction cones ``K f >= k`` for the QP's and the simulator's forces;
* :func:`walking_reference`: CoM and feet tracked within bounds over the whole walk.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import InverseDynamicsQP, InverseDynamicsStatus
from taskspace.locomotion import whole_body_walking
from taskspace.locomotion.footsteps import StepTiming
from taskspace.locomotion.whole_body_walking import (
    WalkingOptions,
    plan_from_robot,
    walk,
    walking_reference,
)

TIMING = StepTiming(
    single_support=0.5,
    double_support=0.15,
    initial_double_support=0.7,
    final_double_support=1.2,
    weight_shift=0.35,
)


class _Spy(InverseDynamicsQP):
    """Records every controller made and every step it solved (state copies and results)."""

    made: ClassVar[list[_Spy]] = []

    def __init__(self, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        self.steps: list[tuple[np.ndarray, np.ndarray, object]] = []
        _Spy.made.append(self)

    def solve(self, state):  # type: ignore[no-untyped-def]
        res = super().solve(state)
        self.steps.append((state.q.copy(), state.v.copy(), res))
        return res


@pytest.fixture(scope="module")
def g1_walk(robot_loader):
    robot = robot_loader("g1")
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.08, timing=TIMING)
    opts = WalkingOptions()
    _Spy.made = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(whole_body_walking, "InverseDynamicsQP", _Spy)
        res = walk(robot, plan, opts)
    return robot, plan, opts, res, list(_Spy.made)


@pytest.mark.slow
def test_one_controller_serves_the_whole_walk(g1_walk):
    _robot, _plan, opts, res, made = g1_walk
    assert res.success, res.message
    assert len(made) == 1  # one controller, its contacts changed 6 times
    qp = made[0]
    assert res.solves["contact_changes"] == qp.contacts_version == 6
    # one solve per sample: the samples are distinct times and carry the solved torques
    assert np.all(np.diff(res.times) > 1e-9)
    assert len(qp.steps) == len(res.times)
    for k, (q, v, step) in enumerate(qp.steps):
        assert q == pytest.approx(res.q[k], abs=0) and v == pytest.approx(res.v[k], abs=0)
        assert np.array_equal(step.tau, res.tau[k])  # type: ignore[attr-defined]
        # the controller's contacts are the simulator's (a swinging foot logs a zero wrench)
        held = {f for f, side in zip(opts.feet, ("left", "right")) if res.wrenches[side][k, 2]}
        assert set(step.contacts) == held, (k, step.contacts)  # type: ignore[attr-defined]


@pytest.mark.slow
def test_torques_are_pinocchios_rnea_with_the_active_contacts(g1_walk):
    robot, _plan, opts, res, made = g1_walk
    model, data = robot.model, robot.model.createData()
    contacts = {c.frame: c for c in made[0].contacts}  # both feet again at the end
    assert len(contacts) == 2
    released = 0
    for q, v, step in made[0].steps:
        assert step.status is InverseDynamicsStatus.SOLVED
        rhs = pin.rnea(model, data, q, v, step.a)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for frame in step.contacts:
            J = pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL)
            f = step.forces[frame]
            rhs -= J.T @ f
            K, k = contacts[frame].cone()
            bound = step.releasing.get(frame)
            if bound is None:
                assert np.all(K @ f >= k - 1e-6), (frame, (K @ f - k).min())
            else:  # being released: friction and CoP rows hold, 0 <= f_z <= the ramp's bound
                released += 1
                rows = ~np.all(K == np.eye(6)[2], axis=1)
                assert np.all(K[rows] @ f >= k[rows] - 1e-6)
                assert -1e-6 <= f[2] <= bound + 1e-6
        scale = np.abs(rhs).max()
        assert np.abs(rhs[:6]).max() <= 1e-6 * scale  # floating base: no torque
        assert step.tau[6:] == pytest.approx(rhs[6:], abs=1e-6 * scale)
    # the two lift-offs: a transition of transition_time, clipped to the double support
    expected = 0
    for before, phase in zip(res.phases, res.phases[1:]):
        if phase[0] == "single_support":
            steps = round((before[2] - before[1]) / opts.dt)
            expected += min(steps, round(opts.transition_time / opts.dt))
    assert released == expected > 70


@pytest.mark.slow
def test_the_whole_walk_tracks_its_reference(g1_walk):
    robot, plan, opts, res, _made = g1_walk
    ref = walking_reference(robot, plan, opts)
    k = np.minimum(np.round(res.times / opts.dt).astype(int), len(ref.times) - 1)
    assert np.abs(res.com - ref.com[k]).max() < 0.01  # CoM within 1 cm of the LIPM
    for side, frame in zip(("left", "right"), opts.feet):
        p = np.array([robot.frame_placement(q, frame).translation for q in res.q])
        error = np.linalg.norm(p - ref.foot_position[side][k], axis=1)
        swinging = ref.swinging[side][k]
        assert swinging.sum() > 100
        assert error[swinging].max() < 0.005  # swing foot within 5 mm of its trajectory
        assert error[~swinging].max() < 0.002  # stance foot on its footstep
    # the simulated forces stay in their cones and the ZMP in the support polygon
    assert res.cone_violation <= 1e-6
    assert res.zmp_margin.min() >= -1e-6
