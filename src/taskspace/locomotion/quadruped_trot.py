"""A quasi-static trot of a quadruped on point feet, by one inverse-dynamics controller.

Diagonal pairs of feet swing in turn (front-left with hind-right, then front-right with
hind-left), each swing moving its feet ``step_length`` forward along a
:class:`~taskspace.locomotion.SwingTrajectory`. Between swings the four feet stand while the
CoM moves (minimum-jerk) to where the two diagonals of the feet cross: on the support line of
either pair, so the pair that swings next leaves the CoM above the line of the other. The walk
starts and ends on four feet.

One :class:`~taskspace.control.InverseDynamicsQP` (CoM, base orientation, posture and one
position task per foot, weight 0 while the foot is a contact) computes the torques of the
whole trot with :class:`~taskspace.constraints.PointContact` feet; its contacts change at run
time: before a lift-off a pair is removed with a transition
(:meth:`~taskspace.control.InverseDynamicsQP.remove_contact`: the normal-force bound ramps to
0 over the last ``transition_time`` of the four-feet phase), at touchdown it is added back with
its bound raised linearly from ``min_force`` to the robot's weight over ``transition_time``.
Each phase is simulated by Pinocchio's constraint dynamics with 3-D point contacts at the
stance feet (:func:`~taskspace.control.simulate_with_contacts`).

Thread safety: :func:`trot` builds its state, tasks, controller and rollouts per call; options
and results are immutable values / plain result data.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace import features as F
from taskspace._validation import FloatArray, check_int, check_positive
from taskspace.constraints import PointContact
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP, simulate_with_contacts
from taskspace.errors import InvalidInputError
from taskspace.locomotion.footsteps import Footstep
from taskspace.locomotion.swing_trajectory import SwingTrajectory
from taskspace.tasks import Task
from taskspace.trajopt import MinimumJerkProfile, PointToPointMotion


@dataclass(frozen=True, kw_only=True)
class TrotOptions:
    """Settings of :func:`trot`.

    Attributes:
        feet: foot frames (front-left, front-right, hind-left, hind-right).
        base: frame whose orientation is held.
        step_length: how far a swing moves its feet forward [m].
        swing_time: duration of a swing [s].
        stance_time: four-feet phase between swings (the CoM moves) [s].
        end_time: four-feet phases at the start and the end [s].
        transition_time: force ramps at lift-off and touchdown [s] (at most ``stance_time``).
        clearance: swing apex above the ground [m].
        friction, min_force: the point contacts' Coulomb coefficient and minimum force [N].
        dt: simulation and control period [s].
        com_kp, base_kp, posture_kp, foot_kp: task stiffnesses [1/s^2].
        base_weight, posture_weight, foot_weight: task weights (the CoM task has 1).
        qp: the controller's settings.
    """

    feet: tuple[str, str, str, str] = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
    base: str = "base_link"
    step_length: float = 0.04
    swing_time: float = 0.24
    stance_time: float = 0.3
    end_time: float = 0.3
    transition_time: float = 0.06
    clearance: float = 0.03
    friction: float = 0.6
    min_force: float = 0.2
    dt: float = 0.002
    com_kp: float = 100.0
    base_kp: float = 100.0
    posture_kp: float = 30.0
    foot_kp: float = 400.0
    base_weight: float = 1.0
    posture_weight: float = 1e-3
    foot_weight: float = 1.0
    qp: InverseDynamicsOptions = field(default_factory=InverseDynamicsOptions)

    def __post_init__(self) -> None:
        feet = self.feet
        if (
            not isinstance(feet, tuple | list)
            or len(feet) != 4
            or not all(isinstance(f, str) for f in feet)
            or len(set(feet)) != 4
        ):
            raise InvalidInputError(f"feet must be 4 different frame names, got {feet!r}")
        if not isinstance(self.base, str):
            raise InvalidInputError(f"base must be a frame name, got {self.base!r}")
        if not isinstance(self.qp, InverseDynamicsOptions):
            raise InvalidInputError(
                f"qp must be InverseDynamicsOptions, got {type(self.qp).__name__}"
            )
        for name in ("swing_time", "stance_time", "end_time", "dt", "step_length"):
            check_positive(getattr(self, name), name, strict=name != "step_length")
        for name in ("transition_time", "clearance", "min_force"):
            check_positive(getattr(self, name), name, strict=False)
        check_positive(self.friction, "friction")
        if self.transition_time > self.stance_time:
            raise InvalidInputError(
                f"transition_time ({self.transition_time:g} s) must be at most stance_time "
                f"({self.stance_time:g} s): the ramps run inside the four-feet phases"
            )


@dataclass(frozen=True)
class TrotResult:
    """A simulated trot (one sample per applied torque).

    Attributes:
        success: the trot finished with every simulated contact force in its cone (minimum
            force 0 while a foot is released).
        times: (T,) [s]; q: (T, nq); v: (T, nv); tau: (T, nv).
        com, com_reference: (T, 3) [m].
        feet: per foot frame, (T, 3) simulated position [m].
        foot_reference: per foot frame, (T, 3) its swing trajectory while it swings, its
            footstep otherwise [m].
        swinging: per foot frame, (T,) the foot swings.
        forces: per foot frame, (T, 3) simulated contact force (world axes; zero while it
            swings) [N].
        cone_violation: largest violation of a friction cone over the trot [N].
        contact_changes: how often the controller's contact set changed.
        control_times: (T,) wall time of each QP solve [s].
        message: why the trot stopped early, if it did.
    """

    success: bool
    times: FloatArray
    q: FloatArray
    v: FloatArray
    tau: FloatArray
    com: FloatArray
    com_reference: FloatArray
    feet: dict[str, FloatArray]
    foot_reference: dict[str, FloatArray]
    swinging: dict[str, Any]
    forces: dict[str, FloatArray]
    cone_violation: float
    contact_changes: int
    control_times: FloatArray
    message: str = ""


def _crossing(feet_xy: dict[str, FloatArray], order: tuple[str, str, str, str]) -> FloatArray:
    """Where the diagonals front-left/hind-right and front-right/hind-left cross (x, y)."""
    fl, fr, hl, hr = (feet_xy[f] for f in order)
    try:
        t = np.linalg.solve(np.column_stack([hr - fl, fr - hl]), fr - fl)
    except np.linalg.LinAlgError as exc:
        raise InvalidInputError("the feet's diagonals are parallel: no crossing") from exc
    return np.asarray(fl + t[0] * (hr - fl))


def trot(robot: Any, n_swings: int, options: TrotOptions | None = None) -> TrotResult:
    """Simulate ``robot`` trotting ``n_swings`` swings from its default posture.

    See the module docstring. ``n_swings`` alternates the diagonal pairs (an even number
    brings every foot ``n_swings / 2`` steps forward).
    """
    opts = options or TrotOptions()
    n_swings = check_int(n_swings, "n_swings")
    if n_swings < 1:
        raise InvalidInputError(f"a trot needs n_swings >= 1, got {n_swings}")
    fl, fr, hl, hr = opts.feet
    pairs = ((fl, hr), (fr, hl))
    dt = opts.dt
    q0 = robot.q_default.copy()
    state = robot.state(q0, np.zeros(robot.nv))
    weight = robot.mass * float(np.linalg.norm(robot._model.gravity.linear))
    c0 = np.asarray(state.com()).copy()
    phases: list[tuple[float, tuple[str, ...]]] = [(opts.end_time, ())]
    for i in range(n_swings):
        phases += [(opts.swing_time, pairs[i % 2]), (opts.stance_time, ())]
    phases[-1] = (opts.end_time, ())
    # footsteps after each phase, the CoM's moves over the four-feet phases
    feet_xy = {f: robot.frame_placement(q0, f).translation[:2].copy() for f in opts.feet}
    ground = {f: float(robot.frame_placement(q0, f).translation[2]) for f in opts.feet}
    moves: list[tuple[float, float, list[PointToPointMotion]]] = []
    start, here = 0.0, c0[:2].copy()
    total = sum(d for d, _ in phases)
    for duration, swinging in phases:
        for f in swinging:
            feet_xy[f] = feet_xy[f] + np.array([opts.step_length, 0.0])
        if not swinging and start > 0:
            target = _crossing(feet_xy, opts.feet)
            hold = opts.transition_time if start + duration < total - 1e-9 else 0.0
            length = duration - hold
            profile = MinimumJerkProfile()
            axes = [PointToPointMotion(here[i], target[i], length, profile) for i in (0, 1)]
            moves.append((start, length, axes))
            here = target
        start += duration

    def com_reference(t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        p, dp, ddp = c0[:2].copy(), np.zeros(2), np.zeros(2)
        for t_start, length, axes in moves:
            if t >= t_start:
                e = [m.evaluate(np.array([min(t - t_start, length)])) for m in axes]
                p = np.array([e[0].position[0], e[1].position[0]])
                dp = np.array([e[0].velocity[0], e[1].velocity[0]])
                ddp = np.array([e[0].acceleration[0], e[1].acceleration[0]])
        return np.array([*p, c0[2]]), np.array([*dp, 0.0]), np.array([*ddp, 0.0])

    contacts = {
        f: PointContact(
            robot, f, friction=opts.friction, min_force=opts.min_force, max_force=10 * weight
        )
        for f in opts.feet
    }
    com = Task(F.CenterOfMass(robot), c0, kp=opts.com_kp, name="com")
    base = Task(F.Orientation(robot, opts.base), weight=opts.base_weight, kp=opts.base_kp)
    base.set_target_from_state(state)
    posture = Task(F.JointConfiguration(robot), q0, weight=opts.posture_weight, kp=opts.posture_kp)
    foot_tasks = {f: Task(F.Position(robot, f), weight=0.0, kp=opts.foot_kp) for f in opts.feet}
    for task in foot_tasks.values():
        task.set_target_from_state(state)
    qp = InverseDynamicsQP(
        robot, [com, base, posture, *foot_tasks.values()], list(contacts.values()), opts.qp
    )
    n_ramp = max(1, round(opts.transition_time / dt)) if opts.transition_time > 0 else 0
    logs: dict[str, list[Any]] = {k: [] for k in ("t", "q", "v", "tau", "com", "cref")}
    feet_log: dict[str, list[FloatArray]] = {f: [] for f in opts.feet}
    ref_log: dict[str, list[FloatArray]] = {f: [] for f in opts.feet}
    swing_log: dict[str, list[Any]] = {f: [] for f in opts.feet}
    force_log: dict[str, list[FloatArray]] = {f: [] for f in opts.feet}
    control_times: list[float] = []
    applied: list[FloatArray] = []
    worst_cone = -np.inf
    landed = {f: np.array([*robot.frame_placement(q0, f).translation]) for f in opts.feet}
    q, v, t0 = q0, np.zeros(robot.nv), 0.0
    message = ""
    for index, (duration, swinging) in enumerate(phases):
        steps = round(duration / dt)
        last = index == len(phases) - 1
        active = set(qp.contacts)
        for f in opts.feet:
            c = contacts[f]
            if f not in swinging and c not in active:
                qp.add_contact(c)  # touchdown
            elif f in swinging and c in active and f not in qp.releasing:
                qp.remove_contact(f)  # no transition
            foot_tasks[f].weight = opts.foot_weight if f in swinging else 0.0
            c.max_normal_force = None
        touched = [f for f in opts.feet if index > 0 and f in phases[index - 1][1]]
        lifting = [f for f in opts.feet if not last and f in phases[index + 1][1]]
        swings = {}
        for f in swinging:
            end = landed[f] + np.array([opts.step_length, 0.0, 0.0])
            swings[f] = SwingTrajectory(
                Footstep("left", landed[f][0], landed[f][1]),  # the side is a label here
                Footstep("left", end[0], end[1]),
                duration,
                clearance=opts.clearance,
                lift_height=ground[f],
                land_height=ground[f],
            )
            landed[f] = end
        lift_start = steps - min(n_ramp, steps)

        def control(
            t: float,
            q: FloatArray,
            v: FloatArray,
            steps: int = steps,
            last: bool = last,
            t0: float = t0,
            swings: dict[str, SwingTrajectory] = swings,
            touched: list[str] = touched,
            lifting: list[str] = lifting,
            lift_start: int = lift_start,
        ) -> FloatArray:
            k = round(t / dt)
            if k >= steps and not last and applied:
                return applied[0]  # the next phase's first sample: solved there
            c, cd, cdd = com_reference(t0 + t)
            com.set_target(c)
            com.set_reference(cd, cdd)
            for f, traj in swings.items():
                s = traj.sample([t])
                foot_tasks[f].set_target(s.position[0])
                foot_tasks[f].set_reference(s.velocity[0], s.acceleration[0])
            for f in touched:  # touchdown: the bound rises from min_force to the weight
                alpha = min(1.0, t / opts.transition_time) if opts.transition_time else 1.0
                contacts[f].max_normal_force = (
                    None if alpha >= 1.0 else opts.min_force + alpha * (weight - opts.min_force)
                )
            if n_ramp and k == lift_start:
                for f in lifting:
                    qp.remove_contact(f, (steps - lift_start) * dt, dt)
            state.update(q, v)
            tic = time.perf_counter()
            res = qp.solve(state)
            control_times.append(time.perf_counter() - tic)
            applied[:] = [res.tau]
            return np.asarray(res.tau)

        stance = [contacts[f] for f in opts.feet if f not in swinging]
        roll = simulate_with_contacts(robot, control, q, v, duration, dt, stance)
        keep = len(roll.t) if last else len(roll.t) - 1
        ts = t0 + roll.t[:keep]
        logs["t"].append(ts)
        for key, values in (("q", roll.q), ("v", roll.v), ("tau", roll.tau), ("com", roll.com)):
            logs[key].append(values[:keep])
        logs["cref"].append(np.array([com_reference(t)[0] for t in ts]))
        for f in opts.feet:
            feet_log[f].append(
                np.array([robot.frame_placement(qk, f).translation for qk in roll.q[:keep]])
            )
            if f in swings:
                ref_log[f].append(swings[f].sample(roll.t[:keep]).position)
            else:
                ref_log[f].append(np.repeat(landed[f][None], keep, axis=0))
            swing_log[f].append(np.full(keep, f in swings))
            if f in swings:
                force_log[f].append(np.zeros((keep, 3)))
                continue
            force = roll.forces[f][:keep]
            force_log[f].append(force)
            K, k_min = contacts[f].cone()
            bound = k_min - force.dot(K.T)
            if f in lifting and n_ramp:  # released: minimum force 0 from the ramp's start
                normal = np.all(K == np.eye(3)[2], axis=1) & (k_min > 0)
                bound[lift_start:, normal] -= k_min[normal]
            worst_cone = max(worst_cone, float(bound.max(initial=-np.inf)))
        q, v, t0 = roll.q[-1], roll.v[-1], t0 + steps * dt
        if roll.com[-1, 2] < 0.5 * c0[2]:
            message = f"the robot fell during phase {index} (t = {t0:.2f} s)"
            break
    for c in contacts.values():
        c.max_normal_force = None
    return TrotResult(
        success=not message and worst_cone <= 1e-6,
        times=np.concatenate(logs["t"]),
        q=np.vstack(logs["q"]),
        v=np.vstack(logs["v"]),
        tau=np.vstack(logs["tau"]),
        com=np.vstack(logs["com"]),
        com_reference=np.vstack(logs["cref"]),
        feet={f: np.vstack(x) for f, x in feet_log.items()},
        foot_reference={f: np.vstack(x) for f, x in ref_log.items()},
        swinging={f: np.concatenate(x) for f, x in swing_log.items()},
        forces={f: np.vstack(x) for f, x in force_log.items()},
        cone_violation=float(worst_cone),
        contact_changes=qp.contacts_version,
        control_times=np.array(control_times),
        message=message,
    )
