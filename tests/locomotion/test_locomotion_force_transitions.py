"""Contact transitions with force ramps (TSID's lift-off transition, and a touchdown ramp).

References: the contact forces of the rigid-contact simulator (Pinocchio's constraint
dynamics under the controller's torques), their friction cones, and the linear ramps the
transitions prescribe, recomputed here from the simulated forces and the phase times.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP, simulate_with_contacts
from taskspace.errors import InvalidInputError
from taskspace.locomotion.footsteps import StepTiming
from taskspace.locomotion.whole_body_walking import (
    WalkingOptions,
    plan_from_robot,
    walk,
    walking_reference,
)
from taskspace.tasks import Task

TIMING = StepTiming(
    single_support=0.5,
    double_support=0.15,
    initial_double_support=0.7,
    final_double_support=1.2,
    weight_shift=0.35,
)
FEET = ("left_ankle_roll_link", "right_ankle_roll_link")


def test_normal_force_limit_is_validated(robot_loader):
    robot = robot_loader("g1")
    free = Contact6D(robot, FEET[0])
    assert free.normal_force_limit is None and free.max_force_row is None
    with pytest.raises(InvalidInputError, match="max_force"):
        free.set_normal_force_limit(10.0)
    c = Contact6D(robot, FEET[0], min_force=2.0, max_force=500.0)
    assert c.max_force_row == c.cone()[0].shape[0] - 1
    assert c.normal_force_limit == 500.0
    c.set_normal_force_limit(20.0)
    assert c.normal_force_limit == 20.0
    with pytest.raises(InvalidInputError, match=r"\[min_force, max_force\]"):
        c.set_normal_force_limit(1.0)
    with pytest.raises(InvalidInputError, match=r"\[min_force, max_force\]"):
        c.set_normal_force_limit(600.0)
    c.set_normal_force_limit(None)
    assert c.normal_force_limit == 500.0
    K, k = c.cone()  # the cone keeps max_force
    assert k[-1] == -500.0 and K[-1, 2] == -1.0


@pytest.mark.parametrize("hierarchical", [False, True], ids=["weighted", "hierarchical"])
def test_limit_binds_the_simulated_force_of_a_standing_robot(robot_loader, hierarchical):
    """Standing G1: the left foot's limit set below its natural share (about half the weight)
    caps the simulator's force at the limit; without it the share comes back. The plain
    InverseDynamicsQP reads the limit at every step, weighted and hierarchical."""
    robot = robot_loader("g1")
    q0 = robot.q_default
    weight = robot.mass * 9.81
    contacts = [Contact6D(robot, FEET[0], half_length=0.05, half_width=0.025, max_force=2 * weight)]
    contacts.append(Contact6D(robot, FEET[1], half_length=0.05, half_width=0.025))
    state = robot.state(q0, np.zeros(robot.nv))
    com = Task(F.CenterOfMass(robot), np.asarray(state.com()).copy(), kp=100.0)
    posture = Task(F.JointConfiguration(robot), q0, weight=1e-3, kp=30.0)
    options = InverseDynamicsOptions(hierarchical=hierarchical)
    qp = InverseDynamicsQP(robot, [com, posture], contacts, options)
    limit = 0.3 * weight

    def control(t, q, v):
        contacts[0].set_normal_force_limit(limit if t < 0.06 else None)
        state.update(q, v)
        return qp.solve(state).tau

    roll = simulate_with_contacts(robot, control, q0, np.zeros(robot.nv), 0.12, 0.004, contacts)
    fz = roll.forces[FEET[0]][:, 2]
    held = roll.t < 0.06 - 1e-9
    assert fz[held] == pytest.approx(limit, abs=1e-6)  # the bound binds in the simulator
    assert fz[-1] > 0.4 * weight  # released: the natural share is back
    assert max(roll.cone_violations.values()) <= 1e-6


@pytest.fixture(scope="module")
def ramped_walk(robot_loader):
    robot = robot_loader("g1")
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.08, timing=TIMING)
    opts = WalkingOptions()
    return robot, opts, walk(robot, plan, opts)


@pytest.mark.slow
def test_lifting_foot_ramps_to_zero_and_landing_foot_ramps_up(ramped_walk):
    """Lift-off: the foot's simulated normal force stays under TSID's ramp from its force when
    the transition starts down to 0 over the last ``transition_time`` of the double support
    (``remove_contact(frame, transition_time, dt)``), and is 0 at the last sample before the
    foot is released. Touchdown: from ``min_force`` under the line up to the weight."""
    robot, opts, res = ramped_walk
    assert res.success, res.message
    assert res.cone_violation <= 1e-6
    assert res.zmp_margin.min() >= -1e-6
    weight = robot.mass * 9.81
    dt = opts.dt
    t = res.times
    assert np.all(np.diff(t) > 1e-9)  # one sample per applied torque, no repeated instant
    lifts = 0
    for before_phase, single, after_phase in zip(res.phases, res.phases[1:], res.phases[2:]):
        if single[0] != "single_support":
            continue
        first = int(np.searchsorted(t, single[1] - 1e-9))  # first sample of the swing
        swing = next(s for s in ("left", "right") if res.wrenches[s][first, 2] == 0.0)
        fz = res.wrenches[swing][:, 2]
        lifts += 1
        # lift-off: n steps, the last applied sample of the double support is step n
        steps = round((before_phase[2] - before_phase[1]) / dt)
        n = min(steps, round(opts.transition_time / dt))
        f0 = fz[first - n - 1]  # the force before the transition (its f_start)
        assert f0 > 0.1 * weight
        j = np.arange(1, n + 1)
        ramp = fz[first - n : first]
        assert np.all(ramp <= f0 * (1 - j / n) + 1e-6)
        assert abs(fz[first - 1]) <= 1e-6  # unloaded when the simulator lets it go
        assert np.all(fz[first : first + 10] == 0.0)
        # touchdown (first sample of the next double support): from min_force, under
        # min_force + (weight - min_force) t / ramp
        after = int(np.searchsorted(t, after_phase[1] - 1e-9))
        assert fz[after - 1] == 0.0
        steps = round((after_phase[2] - after_phase[1]) / dt)
        ramp_time = min(steps, round(opts.transition_time / dt)) * dt
        window = after + np.flatnonzero(t[after : after + 100] - t[after] < ramp_time - 1e-9)
        line = opts.min_force + (t[window] - t[after]) / ramp_time * (weight - opts.min_force)
        assert fz[after] == pytest.approx(opts.min_force, abs=1e-6)
        assert np.all(fz[window] <= line + 1e-6)
        assert len(window) > 30
    assert lifts == 2
    # no force jumps: per control step the normal forces change by under 4 % of the weight
    # (the ramps themselves allow weight * dt / ramp = 2.7 %); at a touchdown by min_force
    for side in ("left", "right"):
        jumps = np.abs(np.diff(res.wrenches[side][:, 2]))
        assert jumps.max() < 0.04 * weight


@pytest.mark.slow
def test_walking_reference_is_what_the_walk_tracks(ramped_walk, robot_loader):
    """walking_reference (the peers' input) samples the walk's own CoM reference, and its
    swing-foot reference ends on the footsteps the simulated feet landed on."""
    robot, opts, res = ramped_walk
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.08, timing=TIMING)
    ref = walking_reference(robot, plan, opts)
    k = np.minimum(np.round(res.times / opts.dt).astype(int), len(ref.times) - 1)
    assert ref.com[k] == pytest.approx(res.com_reference, abs=1e-12)
    assert [p[3] for p in ref.phases if p[0] == "single_support"] == ["right", "left"]
    for side, frame in zip(("left", "right"), opts.feet):
        assert ref.swinging[side].sum() == pytest.approx(0.5 / opts.dt, abs=1)
        landed = robot.frame_placement(res.q[-1], frame).translation
        assert ref.foot_position[side][-1] == pytest.approx(landed, abs=0.01)
