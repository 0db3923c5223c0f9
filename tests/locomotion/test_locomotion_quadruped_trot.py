"""Solo-12 trots on point feet with one inverse-dynamics controller whose contacts change.

Diagonal pairs swing in turn; before each lift-off the pair's contacts are removed with a
transition (``remove_contact(frame, transition_time, dt)``: the normal-force bound ramps to
0), at touchdown they are added back with their bound raised from ``min_force`` to the weight.
Every phase is simulated by Pinocchio's constraint dynamics with 3-D point contacts at the
stance feet (``simulate_with_contacts``). References, independent of the controller's paths:

* Pinocchio's RNEA with the contacts the controller reports active (world-aligned linear
  Jacobians of ``pin.getFrameJacobian``) equals the torques and is zero on the floating base;
* the simulator holds exactly the feet the controller has as contacts;
* the friction cones ``K f >= k`` of the QP's and the simulator's forces (minimum force 0
  while a foot is released);
* the CoM and swing-foot references (minimum-jerk CoM, :class:`SwingTrajectory` feet),
  tracked within bounds over the whole trot.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import PointContact
from taskspace.control import InverseDynamicsQP, InverseDynamicsStatus, simulate_with_contacts
from taskspace.locomotion import Footstep, SwingTrajectory
from taskspace.tasks import Task
from taskspace.trajopt import MinimumJerkProfile, PointToPointMotion

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
PAIRS = (("FL_FOOT", "HR_FOOT"), ("FR_FOOT", "HL_FOOT"))
DT = 0.002
STAND, SWING, DOUBLE, RAMP = 0.3, 0.24, 0.3, 0.06  # [s]
STEP, CLEARANCE, CYCLES = 0.04, 0.03, 2  # [m], [m], swings of each pair


def _trot(robot):  # type: ignore[no-untyped-def]
    q0 = robot.q_default.copy()
    state = robot.state(q0, np.zeros(robot.nv))
    weight = robot.mass * 9.81
    c0 = np.asarray(state.com()).copy()
    feet0 = {f: robot.frame_placement(q0, f).translation.copy() for f in FEET}
    # phases: (kind, duration, swinging feet); 4 feet at the start, between swings, at the end
    phases = [("stand", STAND, ())]
    for i in range(2 * CYCLES):
        phases += [("swing", SWING, PAIRS[i % 2]), ("stand", DOUBLE, ())]
    phases[-1] = ("stand", STAND, ())
    total = sum(p[1] for p in phases)
    # every swing moves its feet by STEP. While a pair swings the support is the other
    # diagonal: the CoM waits above the crossing of the diagonals (on both), reached by a
    # minimum-jerk move over each four-feet phase but its last RAMP
    feet_xy = {f: p[:2].copy() for f, p in feet0.items()}
    moves, start, here = [], 0.0, c0[:2].copy()
    for kind, duration, swinging in phases:
        for f in swinging:
            feet_xy[f] = feet_xy[f] + [STEP, 0.0]
        if kind == "stand" and start > 0:
            target = _crossing(feet_xy)
            hold = RAMP if start + duration < total - 1e-9 else 0.0
            moves.append((start, duration - hold, here, target))
            here = target
        start += duration

    def com_reference(t: float):  # type: ignore[no-untyped-def]
        p, dp, ddp = moves[0][2], np.zeros(2), np.zeros(2)
        for t_start, length, a, b in moves:
            if t >= t_start:
                tau = min(t - t_start, length)
                m = [PointToPointMotion(a[i], b[i], length, MinimumJerkProfile()) for i in (0, 1)]
                e = [mi.evaluate(np.array([tau])) for mi in m]
                p = np.array([e[0].position[0], e[1].position[0]])
                dp = np.array([e[0].velocity[0], e[1].velocity[0]])
                ddp = np.array([e[0].acceleration[0], e[1].acceleration[0]])
        return np.array([*p, c0[2]]), np.array([*dp, 0.0]), np.array([*ddp, 0.0])

    contacts = {
        f: PointContact(robot, f, friction=0.6, min_force=0.2, max_force=10 * weight) for f in FEET
    }
    com = Task(F.CenterOfMass(robot), c0, kp=100.0, name="com")
    base = Task(F.Orientation(robot, "base_link"), weight=1.0, kp=100.0, name="base")
    base.set_target_from_state(state)
    posture = Task(F.JointConfiguration(robot), q0, weight=1e-3, kp=30.0)
    feet = {f: Task(F.Position(robot, f), weight=0.0, kp=400.0, name=f) for f in FEET}
    for task in feet.values():
        task.set_target_from_state(state)
    qp = InverseDynamicsQP(robot, [com, base, posture, *feet.values()], list(contacts.values()))
    log = {"t": [], "q": [], "v": [], "tau": [], "f": [], "held": [], "steps": []}
    log["foot_ref"] = []
    q, v, t0 = q0, np.zeros(robot.nv), 0.0
    landed = dict(feet0)
    applied: list[np.ndarray] = []
    for index, (_kind, duration, swinging) in enumerate(phases):
        steps = round(duration / DT)
        last = index == len(phases) - 1
        for f in FEET:
            c = contacts[f]
            if f not in swinging and c not in qp.contacts:
                qp.add_contact(c)  # touchdown
            feet[f].weight = 1.0 if f in swinging else 0.0
            c.max_normal_force = None
        touched = [f for f in FEET if index >= 2 and f in phases[index - 1][2]]
        lifting = [f for f in FEET if not last and f in phases[index + 1][2]]
        swings = {}
        for f in swinging:
            start = landed[f]
            end = start + np.array([STEP, 0.0, 0.0])
            swings[f] = SwingTrajectory(
                Footstep("left", *start[:2]),
                Footstep("left", *end[:2]),
                duration,
                clearance=CLEARANCE,
                lift_height=start[2],
                land_height=start[2],
            )
            landed[f] = end

        def control(
            t, q, v, steps=steps, last=last, t0=t0, swings=swings, touched=touched, lifting=lifting
        ):  # type: ignore[no-untyped-def]
            k = round(t / DT)
            if k >= steps and not last:
                return applied[0]  # the next phase's first sample: solved there
            c, cd, cdd = com_reference(t0 + t)
            com.set_target(c)
            com.set_reference(cd, cdd)
            refs = {}
            for f, traj in swings.items():
                s = traj.sample([t])
                feet[f].set_target(s.position[0])
                feet[f].set_reference(s.velocity[0], s.acceleration[0])
                refs[f] = s.position[0]
            for f in touched:  # touchdown ramp of the bound
                alpha = min(1.0, t / RAMP)
                contacts[f].max_normal_force = (
                    None if alpha >= 1 else (0.2 + alpha * (weight - 0.2))
                )
            if lifting and k == steps - round(RAMP / DT):
                for f in lifting:
                    qp.remove_contact(f, RAMP, DT)
            state.update(q, v)
            res = qp.solve(state)
            applied[:] = [res.tau]
            log["steps"].append((q.copy(), v.copy(), res))
            log["foot_ref"].append(refs)
            return res.tau

        stance = [contacts[f] for f in FEET if f not in swinging]
        roll = simulate_with_contacts(robot, control, q, v, duration, DT, stance)
        keep = len(roll.t) if last else len(roll.t) - 1
        log["t"].append(t0 + roll.t[:keep])
        log["q"].append(roll.q[:keep])
        log["held"] += [tuple(c.frame for c in stance)] * keep
        log["f"] += [{f: roll.forces[f][k] for f in roll.forces} for k in range(keep)]
        q, v, t0 = roll.q[-1], roll.v[-1], t0 + steps * DT
    out = {k: np.concatenate(log[k]) for k in ("t", "q")}
    out.update(
        steps=log["steps"],
        held=log["held"],
        forces=log["f"],
        foot_ref=log["foot_ref"],
        com_reference=com_reference,
        landed=landed,
        contacts=contacts,
        qp=qp,
        weight=weight,
    )
    return out


def _crossing(feet_xy: dict) -> np.ndarray:  # type: ignore[type-arg]
    """Where the diagonals FL-HR and FR-HL cross (x, y)."""
    p, q = feet_xy["FL_FOOT"], feet_xy["HR_FOOT"]
    r, s = feet_xy["FR_FOOT"], feet_xy["HL_FOOT"]
    t = np.linalg.solve(np.column_stack([q - p, r - s]), r - p)
    return np.asarray(p + t[0] * (q - p))


@pytest.fixture(scope="module")
def trot(robot_loader):
    robot = robot_loader("solo12")
    return robot, _trot(robot)


@pytest.mark.slow
def test_solo12_trots_with_one_controller(trot):
    robot, run = trot
    steps = run["steps"]
    assert len(steps) == len(run["t"])  # one solve per sample
    assert run["qp"].contacts_version == 3 * 2 * 2 * CYCLES  # 2 removals (ramp, drop) + 1 add
    model, data = robot.model, robot.model.createData()
    released = 0
    for k, (q, v, res) in enumerate(steps):
        assert res.status is InverseDynamicsStatus.SOLVED
        assert set(res.contacts) == set(run["held"][k])  # the simulator's contacts
        rhs = pin.rnea(model, data, q, v, res.a)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for frame in res.contacts:
            J = pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL_WORLD_ALIGNED)
            f = res.forces[frame]
            rhs -= J[:3].T @ f
            K, kk = run["contacts"][frame].cone()
            for force in (f, run["forces"][k][frame]):  # the QP's and the simulator's
                lo = kk.copy()
                if frame in res.releasing:
                    released += 1
                    lo[4] = 0.0  # minimum force 0 while released
                    assert force[2] <= res.releasing[frame] + 1e-6
                assert np.all(K @ force >= lo - 1e-6), (k, frame, (K @ force - lo).min())
        scale = np.abs(rhs).max()
        assert np.abs(rhs[:6]).max() <= 1e-6 * scale
        assert res.tau[6:] == pytest.approx(rhs[6:], abs=1e-6 * scale)
    assert released == 2 * 2 * 2 * CYCLES * round(RAMP / DT)  # QP + simulator, per foot


@pytest.mark.slow
def test_trot_tracks_its_com_and_feet(trot):
    robot, run = trot
    com = np.array([pin.centerOfMass(robot.model, robot.model.createData(), q) for q in run["q"]])
    reference = np.array([run["com_reference"](t)[0] for t in run["t"]])
    assert np.abs(com - reference).max() < 0.005  # 3.3 mm
    assert com[-1, 0] - com[0, 0] == pytest.approx(CYCLES * STEP, abs=0.005)
    worst = 0.0
    for q, refs in zip(run["q"], run["foot_ref"]):
        for frame, p in refs.items():
            worst = max(
                worst, float(np.linalg.norm(robot.frame_placement(q, frame).translation - p))
            )
    assert worst < 0.003  # swing feet within 3 mm of their trajectories (0.95 mm)
    for frame, p in run["landed"].items():  # every foot ends on its last footstep
        assert robot.frame_placement(run["q"][-1], frame).translation == pytest.approx(p, abs=3e-3)
