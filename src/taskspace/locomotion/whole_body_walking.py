"""Whole-body walking: LIPM CoM and swing-foot references tracked by the inverse-dynamics QP.

The walk is a :class:`~taskspace.locomotion.footsteps.FootstepPlan` whose footsteps are the
positions of the foot frames on the ground. Per contact phase:

* the CoM reference (position, velocity, acceleration) comes from the preview controller on
  the cart-table model at the robot's initial CoM height;
* in single support the swing foot follows a :class:`SwingTrajectory` (position task with
  feed-forward velocity and acceleration) and keeps its initial orientation turned by the
  change of yaw from its initial footstep (footstep yaws are absolute, world frame: a foot
  lands at its footstep's yaw whatever the robot's initial heading); the stance foot is a
  rigid 6-D contact (friction cone, CoP in the sole);
* in double support both feet are contacts;
* a pelvis orientation task (turning with the feet) and a posture task take the remaining
  freedom.

One :class:`~taskspace.control.InverseDynamicsQP` computes the torques of the whole walk; its
contacts change at run time (:meth:`~taskspace.control.InverseDynamicsQP.remove_contact` at
lift-off, :meth:`~taskspace.control.InverseDynamicsQP.add_contact` at touchdown) and both feet's
swing tasks are in it from the start, with weight 0 while the foot is a contact. The robot is
simulated phase by phase with rigid contacts (:func:`~taskspace.control.simulate_with_contacts`,
Pinocchio's constraint dynamics), the simulated contact set switched at lift-off and touchdown,
a landing foot anchored where it touches down. The switches carry force transitions, as TSID's
contact transitions do: a foot that lifts at the end of a double support is removed with a
transition (``remove_contact(frame, transition_time, dt)``): over the last ``transition_time``
of the double support the upper bound of its normal force ramps linearly from its current
force down to 0 (the foot leaves the ground unloaded); a foot that lands is added with its
normal-force bound (:attr:`~taskspace.constraints.contact.Contact.max_normal_force`) at the
contacts' minimum force, raised linearly to the robot's weight over the first
``transition_time`` of the double support (the load builds up at a bounded rate).

The contacts, their CoP rectangles and the measured ZMP live in the plane of the foot frames
at the start (for G1 the ankle-roll frames, 35 mm above the soles; for Talos the sole
frames).

Thread safety: :func:`walk` builds its state, tasks, inverse-dynamics controller and rollout
per call, so walks may run in several threads (one robot may be shared as far as
:class:`~taskspace.model.Robot` allows: do not change its model or world meanwhile). Options,
references and results are immutable.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace import features as F
from taskspace._validation import FloatArray
from taskspace.constraints import Contact6D
from taskspace.constraints.contact import Contact
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP, simulate_with_contacts
from taskspace.errors import InvalidInputError
from taskspace.locomotion.footsteps import (
    Footstep,
    FootstepPlan,
    PhaseKind,
    StepTiming,
    check_plan,
    check_steps,
    footsteps_along_poses,
)
from taskspace.locomotion.lipm import CartTable
from taskspace.locomotion.preview_control import PreviewController
from taskspace.locomotion.support_polygon import SupportPolygon
from taskspace.locomotion.swing_trajectory import SwingTrajectory
from taskspace.locomotion.zmp import ContactWrench, zmp_from_wrenches
from taskspace.locomotion.zmp_reference import zmp_reference
from taskspace.tasks import Task


@dataclass(frozen=True, kw_only=True)
class WalkingOptions:
    """Settings of :func:`walk`.

    Attributes:
        feet: ``(left, right)`` foot frames (z axis normal to the sole).
        pelvis: frame whose orientation is held.
        sole_half_length, sole_half_width: CoP rectangle of the contacts around the foot
            frame origin [m].
        friction: Coulomb coefficient of the contacts.
        clearance: swing-foot apex height [m].
        dt: simulation and control period [s].
        com_kp, foot_kp, pelvis_kp, posture_kp: task stiffnesses [1/s^2].
        foot_weight, pelvis_weight, posture_weight: task weights (the CoM task has 1).
        transition_time: duration of the force ramps at lift-off and touchdown [s] (clipped
            to the double support; 0: no ramps, the contacts switch with whatever force the
            ZMP reference leaves on them).
        min_force: the contacts' minimum normal force [N] (the touchdown ramp starts there;
            the lift-off ramp ends at 0).
    """

    feet: tuple[str, str] = ("left_ankle_roll_link", "right_ankle_roll_link")
    pelvis: str = "pelvis"
    sole_half_length: float = 0.05
    sole_half_width: float = 0.025
    friction: float = 0.8
    clearance: float = 0.04
    dt: float = 0.004
    com_kp: float = 100.0
    foot_kp: float = 400.0
    pelvis_kp: float = 100.0
    posture_kp: float = 30.0
    foot_weight: float = 1.0
    pelvis_weight: float = 0.1
    posture_weight: float = 1e-3
    transition_time: float = 0.15
    min_force: float = 1.0
    qp: InverseDynamicsOptions = field(default_factory=InverseDynamicsOptions)


@dataclass(frozen=True)
class WalkingResult:
    """A simulated walk.

    Attributes:
        success: the walk finished with every contact force inside its cone and the
            measured ZMP inside the support polygon.
        times: (T,) [s], strictly increasing: one sample per applied torque (a phase's last
            simulated sample is the next phase's first, kept once); q: (T, nq); v: (T, nv);
            tau: (T, nv).
        com: (T, 3) simulated CoM [m]; com_reference: (T, 3).
        zmp: (T, 2) ZMP of the simulated contact forces [m].
        zmp_margin: (T,) distance of the ZMP to the edge of the CoP rectangles' hull [m].
        cone_violation: largest violation of a friction cone over the walk [N].
        phases: (kind, start, end) of each simulated phase.
        wrenches: per side (``"left"``, ``"right"``), (T, 6) simulated contact wrench in the
            foot frame [N, N m]; zero while the foot swings.
        control_times: (T,) wall time of each QP solve [s] (one per sample).
        message: why the walk stopped early, if it did.
        solves: summary of the QP solves: steps per path and backend (``"compiled
            cholesky"``, ``"compiled proxsuite"``, or the Python path's backends) and the
            largest KKT residuals (primal, dual, complementarity) of the weighted QPs;
            ``contact_changes``: how often the one controller's contact set changed
            (``InverseDynamicsQP.contacts_version``).
    """

    success: bool
    times: FloatArray
    q: FloatArray
    v: FloatArray
    tau: FloatArray
    com: FloatArray
    com_reference: FloatArray
    zmp: FloatArray
    zmp_margin: FloatArray
    cone_violation: float
    phases: list[tuple[str, float, float]]
    wrenches: dict[str, FloatArray]
    control_times: FloatArray
    message: str = ""
    solves: dict[str, Any] = field(default_factory=dict)


def plan_from_robot(
    robot: Any,
    q: Any,
    n_steps: int,
    *,
    step_length: float = 0.1,
    yaw_per_step: float = 0.0,
    feet: tuple[str, str] = ("left_ankle_roll_link", "right_ankle_roll_link"),
    timing: StepTiming | None = None,
) -> FootstepPlan:
    """A walk from the robot's current feet: ``n_steps`` steps (the last closes the feet).

    The body starts between the feet, heading perpendicular to the line from the right foot
    to the left one (so the plan's initial feet are the robot's, whatever its yaw), then
    advances ``step_length`` [m] and turns ``yaw_per_step`` [rad] per step; the feet keep
    their current lateral distance.
    """
    n_steps = check_steps(n_steps)
    pl = robot.frame_placement(q, feet[0]).translation
    pr = robot.frame_placement(q, feet[1]).translation
    across = pl[:2] - pr[:2]  # right foot -> left foot: the body's +y
    width = float(np.linalg.norm(across))
    mid = 0.5 * (pl[:2] + pr[:2])
    poses = [(mid[0], mid[1], math.atan2(-float(across[0]), float(across[1])))]
    for _ in range(n_steps - 1):
        x, y, yaw = poses[-1]
        yaw_next = yaw + yaw_per_step
        heading = 0.5 * (yaw + yaw_next)
        poses.append(
            (x + step_length * math.cos(heading), y + step_length * math.sin(heading), yaw_next)
        )
    first = "left" if yaw_per_step > 0 else "right"
    return footsteps_along_poses(
        np.array(poses), step_width=width, first_swing=first, timing=timing
    )


@dataclass(frozen=True)
class WalkingReference:
    """The references :func:`walk` tracks, sampled every ``dt`` over the plan (for peers).

    Attributes:
        times: (N,) [s].
        com, com_velocity, com_acceleration: (N, 3) CoM reference [m, m/s, m/s^2].
        foot_position, foot_velocity, foot_acceleration: per side, (N, 3) foot-frame
            reference (the swing trajectory while the foot swings, its footstep otherwise).
        foot_rotation: per side, (N, 3, 3) orientation target of the foot frame.
        swinging: per side, (N,) the foot swings (no contact).
        pelvis_rotation: (N, 3, 3) orientation target of the pelvis frame.
        phases: (kind, start, end, swing side or ``""``) of each phase.
        q0: the initial configuration.
    """

    times: FloatArray
    com: FloatArray
    com_velocity: FloatArray
    com_acceleration: FloatArray
    foot_position: dict[str, FloatArray]
    foot_velocity: dict[str, FloatArray]
    foot_acceleration: dict[str, FloatArray]
    foot_rotation: dict[str, FloatArray]
    swinging: dict[str, Any]
    pelvis_rotation: FloatArray
    phases: list[tuple[str, float, float, str]]
    q0: FloatArray


def walking_reference(
    robot: Any, plan: FootstepPlan, options: WalkingOptions | None = None
) -> WalkingReference:
    """The CoM, feet and pelvis references of :func:`walk` on a uniform grid.

    The same preview-control CoM, swing trajectories, foot and pelvis orientation targets as
    :func:`walk`, sampled at ``k dt`` (a sample at a phase switch belongs to the next phase):
    what a peer controller needs to track the same walk.

    Raises:
        InvalidInputError: a plan that does not start on the robot's feet (positions or
            yaws), as in :func:`walk`.
    """
    opts = options or WalkingOptions()
    q0 = robot.q_default.copy()
    state = robot.state(q0, np.zeros(robot.nv))
    c0 = np.asarray(state.com()).copy()
    foot_frames = {"left": opts.feet[0], "right": opts.feet[1]}
    foot0 = {s: robot.frame_placement(q0, f) for s, f in foot_frames.items()}
    _check_plan_starts_on_feet(check_plan(plan), foot0)
    ground = {s: float(foot0[s].translation[2]) for s in foot0}
    pelvis0 = robot.frame_placement(q0, opts.pelvis).rotation.copy()
    turn = _TurnFromStart(plan, foot0, pelvis0)
    model = CartTable(com_height=float(c0[2] - np.mean(list(ground.values()))), dt=opts.dt)
    n = math.ceil(plan.duration / opts.dt) + 1
    times: FloatArray = opts.dt * np.arange(n, dtype=np.float64)
    init = np.zeros((3, 2))
    init[0] = c0[:2]
    lipm = PreviewController(model).simulate(zmp_reference(plan, times), init)
    com = np.column_stack([lipm.com[:n], np.full(n, c0[2])])
    com_v = np.column_stack([lipm.com_velocity[:n], np.zeros(n)])
    com_a = np.column_stack([lipm.com_acceleration[:n], np.zeros(n)])
    pos = {s: np.zeros((n, 3)) for s in foot_frames}
    vel = {s: np.zeros((n, 3)) for s in foot_frames}
    acc = {s: np.zeros((n, 3)) for s in foot_frames}
    rot = {s: np.zeros((n, 3, 3)) for s in foot_frames}
    swinging = {s: np.zeros(n, dtype=bool) for s in foot_frames}
    pelvis = np.zeros((n, 3, 3))
    phases = []
    all_phases = plan.phases()
    for index, phase in enumerate(all_phases):
        last = index == len(all_phases) - 1
        ks = np.flatnonzero((times >= phase.start - 1e-9) & ((times < phase.end - 1e-9) | last))
        feet_end = {f.side: f for f in phase.stance}
        if phase.swing is not None:
            feet_end[phase.swing[1].side] = phase.swing[1]
        pelvis[ks] = turn.pelvis(feet_end.values())
        for foot in phase.stance:
            pos[foot.side][ks] = [foot.x, foot.y, ground[foot.side]]
            rot[foot.side][ks] = turn.foot(foot)
        side = ""
        if phase.kind is PhaseKind.SINGLE_SUPPORT and phase.swing is not None:
            land = phase.swing[1]
            side = land.side
            swing = _swing_trajectory(phase, opts.clearance, ground[side]).sample(
                times[ks] - phase.start
            )
            pos[side][ks] = swing.position
            vel[side][ks] = swing.velocity
            acc[side][ks] = swing.acceleration
            rot[side][ks] = turn.foot(land)
            swinging[side][ks] = True
        phases.append((phase.kind.value, phase.start, phase.end, side))
    return WalkingReference(
        times, com, com_v, com_a, pos, vel, acc, rot, swinging, pelvis, phases, q0
    )


@dataclass
class _TouchdownRamp:
    """The normal-force bound of a foot that just landed, raised linearly.

    From ``contact.min_force`` at phase time 0 to ``f_end`` at ``duration``; after it the bound
    is the contact's ``max_force`` again.
    """

    contact: Contact
    duration: float
    f_end: float

    def apply(self, t: float) -> None:
        c = self.contact
        alpha = min(1.0, t / self.duration) if self.duration > 0 else 1.0
        if alpha >= 1.0:
            c.max_normal_force = None
            return
        top = c.max_force if c.max_force is not None else self.f_end
        c.max_normal_force = min(top, c.min_force + alpha * (self.f_end - c.min_force))


@dataclass
class _LiftOff:
    """A foot removed from the controller with a transition starting at phase step ``start``.

    Its ``steps`` solves end with the step before the phase's last sample, so the next phase
    (the foot in the air) starts without it.
    """

    frame: str
    start: int
    steps: int
    dt: float
    started: bool = False


class _PhaseControl:
    """``tau = control(t, q, v)`` of one contact phase (``t`` from the phase start).

    One :class:`InverseDynamicsQP` for the whole walk. The phase's last sample (``t`` at its
    end, ``last_step``) is the first sample of the next phase, whose own solve computes the
    torque applied from there: at the last sample the torque before it is returned (the
    simulator records it but applies nothing after it, and :func:`walk` drops the sample), so
    the controller solves once per applied torque and its transitions count applied steps.
    """

    def __init__(
        self,
        qp: InverseDynamicsQP,
        state: Any,
        com_task: Task,
        com_reference: Callable[[float], tuple[FloatArray, FloatArray, FloatArray]],
        start: float,
        dt: float,
        last_step: int,
        swing: SwingTrajectory | None,
        swing_tasks: dict[str, Task],
        log: list[float],
        touchdown: _TouchdownRamp | None,
        lift_off: _LiftOff | None,
        solves: dict[str, Any],
        tau: list[FloatArray],
    ) -> None:
        self.qp, self.state, self.com_task = qp, state, com_task
        self.com_reference, self.start, self.dt = com_reference, start, dt
        self.last_step = last_step
        self.swing, self.swing_tasks, self.log = swing, swing_tasks, log
        self.touchdown, self.lift_off = touchdown, lift_off
        self.solves = solves
        self.tau = tau  # [the last applied torque], shared by the phases

    def __call__(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        step = round(t / self.dt)
        if step >= self.last_step and self.tau:
            return self.tau[0]
        c, cd, cdd = self.com_reference(self.start + t)
        self.com_task.set_target(c)
        self.com_task.set_reference(cd, cdd)
        if self.swing is not None:
            s = self.swing.sample([t])
            task = self.swing_tasks[self.swing.land.side]
            task.set_target(s.position[0])
            task.set_reference(s.velocity[0], s.acceleration[0])
        if self.touchdown is not None:
            self.touchdown.apply(t)
        lift = self.lift_off
        if lift is not None and not lift.started and step >= lift.start:
            self.qp.remove_contact(lift.frame, lift.steps * lift.dt, lift.dt)
            lift.started = True
        self.state.update(q, v)
        t0 = time.perf_counter()
        res = self.qp.solve(self.state)
        self.log.append(time.perf_counter() - t0)
        _record_solve(self.solves, res)
        tau = np.asarray(res.tau)
        self.tau[:] = [tau]
        return tau


def _record_solve(solves: dict[str, Any], res: Any) -> None:
    """Count ``res``'s path and backend in ``solves``; keep the largest KKT residuals."""
    qp = res.qp
    backend = qp.backend if qp is not None else "cascade"
    key = backend if res.compiled else f"python {backend}"
    paths = solves.setdefault("paths", {})
    paths[key] = paths.get(key, 0) + 1
    if qp is not None:
        for name in ("primal", "dual", "complementarity"):
            value = float(getattr(qp.kkt, name))
            worst = solves.get(f"max_kkt_{name}", 0.0)
            solves[f"max_kkt_{name}"] = value if not value <= worst else worst  # NaN sticks


def _swing_trajectory(phase: Any, clearance: float, height: float) -> SwingTrajectory:
    """The swing foot's trajectory over a single-support ``phase`` (ground at ``height``)."""
    lift, land = phase.swing
    return SwingTrajectory(
        Footstep(land.side, lift.x, lift.y, lift.yaw),
        land,
        phase.end - phase.start,
        clearance=clearance,
        lift_height=height,
        land_height=height,
    )


#: How far [m] a plan's initial footstep may be from the robot's foot at its default posture.
PLAN_START_TOLERANCE = 0.01

#: How far [rad] a plan's initial footstep yaw may be from the robot's heading at its default
#: posture (perpendicular to the line from the right foot to the left one, as
#: :func:`plan_from_robot` reads it).
PLAN_START_YAW_TOLERANCE = 0.05


def _check_plan_starts_on_feet(plan: FootstepPlan, foot0: Mapping[str, pin.SE3]) -> None:
    """Refuse a plan whose initial feet are not where, or not facing as, the robot's feet.

    The stance contacts are the robot's real feet while the ZMP reference and the swing
    targets come from the plan: a plan made for other feet (``straight_walk``'s default
    ``step_width``, another robot) put the ZMP reference outside the real support and the
    simulation diverged, ending in a NotFiniteError deep inside the walk. The feet turn by the
    plan's change of yaw from its initial footsteps, so an initial yaw that is not the
    robot's (a plan for a robot facing another way) counted every turn from the wrong start,
    silently (initial yaws 0.5 rad on a G1 facing 0: its feet turned to -0.5 rad).
    """
    # the robot's heading as plan_from_robot reads it (a toe-out foot frame does not turn it)
    across = np.asarray(foot0["left"].translation[:2]) - np.asarray(foot0["right"].translation[:2])
    heading = math.atan2(-float(across[0]), float(across[1]))
    for foot in plan.initial:
        actual = np.asarray(foot0[foot.side].translation[:2])
        off = float(np.linalg.norm(foot.position - actual))
        if off > PLAN_START_TOLERANCE:
            raise InvalidInputError(
                f"the plan's initial {foot.side} foot is at ({foot.x:.4f}, {foot.y:.4f}) m but the "
                f"robot's {foot.side} foot stands at ({actual[0]:.4f}, {actual[1]:.4f}) m in its "
                f"default posture ({off:.4f} m away, tolerance {PLAN_START_TOLERANCE} m): make "
                "the plan from the robot's feet (plan_from_robot(robot, robot.q_default, ...))"
            )
        apart = abs(math.remainder(foot.yaw - heading, 2.0 * math.pi))
        if apart > PLAN_START_YAW_TOLERANCE:
            raise InvalidInputError(
                f"the plan's initial {foot.side} foot has yaw {foot.yaw:.4f} rad but the robot "
                f"faces {heading:.4f} rad in its default posture (perpendicular to the line "
                f"from its right foot to its left one; {apart:.4f} rad apart, tolerance "
                f"{PLAN_START_YAW_TOLERANCE} rad): footstep yaws are absolute (world frame); "
                "make the plan from the robot's feet (plan_from_robot(robot, robot.q_default, "
                "...))"
            )


def _yaw_rotation(yaw: float) -> FloatArray:
    return np.asarray(pin.rpy.rpyToMatrix(0.0, 0.0, yaw))


def _heading(feet: Iterable[Footstep]) -> float:
    """The mean yaw of ``feet`` [rad] (on the circle)."""
    yaws = [f.yaw for f in feet]
    return math.atan2(sum(map(math.sin, yaws)), sum(map(math.cos, yaws)))


class _TurnFromStart:
    """Orientation targets of the feet and the pelvis for a plan's absolute footstep yaws.

    The robot's feet stand as the plan's initial footsteps say (checked), so a foot landing at
    yaw ``psi`` has turned by ``psi - psi_0`` from its initial footstep's yaw ``psi_0``: its
    target is ``Rz(psi - psi_0) R_foot,0`` (``Rz(psi) R_foot,0`` counted the robot's initial
    yaw twice: a robot facing 0.4 rad walked straight with its feet turned to 0.8). The pelvis
    turns likewise with the mean yaw of the feet.
    """

    def __init__(self, plan: FootstepPlan, foot0: Mapping[str, pin.SE3], pelvis0: FloatArray):
        self._yaw0 = {f.side: f.yaw for f in plan.initial}
        self._rot0 = {side: np.asarray(M.rotation).copy() for side, M in foot0.items()}
        self._heading0 = _heading(plan.initial)
        self._pelvis0 = pelvis0

    def foot(self, step: Footstep) -> FloatArray:
        """Target rotation of the foot of ``step`` standing at ``step.yaw``."""
        return _yaw_rotation(step.yaw - self._yaw0[step.side]) @ self._rot0[step.side]

    def pelvis(self, feet: Iterable[Footstep]) -> FloatArray:
        """Target rotation of the pelvis between ``feet``."""
        return _yaw_rotation(_heading(feet) - self._heading0) @ self._pelvis0


def walk(robot: Any, plan: FootstepPlan, options: WalkingOptions | None = None) -> WalkingResult:
    """Simulate ``robot`` walking ``plan`` from its default posture (see the module docstring).

    Raises:
        InvalidInputError: the plan's initial feet are more than :data:`PLAN_START_TOLERANCE`
            from the robot's feet in its default posture, or their yaws more than
            :data:`PLAN_START_YAW_TOLERANCE` from the robot's heading (make it with
            :func:`plan_from_robot`).
    """
    opts = options or WalkingOptions()
    q0 = robot.q_default.copy()
    v0 = np.zeros(robot.nv)
    state = robot.state(q0, v0)
    c0 = np.asarray(state.com()).copy()
    foot_frames = {"left": opts.feet[0], "right": opts.feet[1]}
    foot0 = {s: robot.frame_placement(q0, f) for s, f in foot_frames.items()}
    _check_plan_starts_on_feet(check_plan(plan), foot0)
    ground = {s: float(foot0[s].translation[2]) for s in foot0}
    # CoM reference from preview control of the ZMP reference
    model = CartTable(com_height=float(c0[2] - np.mean(list(ground.values()))), dt=opts.dt)
    n = math.ceil(plan.duration / opts.dt) + 1
    sample_t = opts.dt * np.arange(n)
    ref = zmp_reference(plan, sample_t)
    init = np.zeros((3, 2))
    init[0] = c0[:2]
    lipm = PreviewController(model).simulate(ref, init)

    def com_reference(t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        k = min(round(t / opts.dt), n - 1)
        return (
            np.array([*lipm.com[k], c0[2]]),
            np.array([*lipm.com_velocity[k], 0.0]),
            np.array([*lipm.com_acceleration[k], 0.0]),
        )

    com_task = Task(F.CenterOfMass(robot), c0, kp=opts.com_kp, name="com")
    pelvis_task = Task(
        F.Orientation(robot, opts.pelvis),
        weight=opts.pelvis_weight,
        kp=opts.pelvis_kp,
        name="pelvis",
    )
    pelvis0 = robot.frame_placement(q0, opts.pelvis).rotation.copy()
    turn = _TurnFromStart(plan, foot0, pelvis0)
    posture = Task(F.JointConfiguration(robot), q0, weight=opts.posture_weight, kp=opts.posture_kp)
    weight = robot.mass * float(np.linalg.norm(robot._model.gravity.linear))
    swing_pos = {
        s: Task(F.Position(robot, f), weight=opts.foot_weight, kp=opts.foot_kp, name=f"{s}_pos")
        for s, f in foot_frames.items()
    }
    swing_rot = {
        s: Task(F.Orientation(robot, f), weight=opts.foot_weight, kp=opts.foot_kp, name=f"{s}_rot")
        for s, f in foot_frames.items()
    }
    contacts = {
        s: Contact6D(
            robot,
            f,
            half_length=opts.sole_half_length,
            half_width=opts.sole_half_width,
            friction=opts.friction,
            min_force=opts.min_force,
            max_force=10.0 * weight,
        )
        for s, f in foot_frames.items()
    }
    # one controller for the whole walk: both feet's swing tasks (weight 0 while the foot is a
    # contact), the contacts of the first phase; lift-off and touchdown change its contacts
    all_phases = plan.phases()
    for s in foot_frames:
        for task in (swing_pos[s], swing_rot[s]):
            task.weight = 0.0
            task.set_target_from_state(state)  # the foot where it stands (weight 0 there)
    qp = InverseDynamicsQP(
        robot,
        [com_task, pelvis_task, posture, *swing_pos.values(), *swing_rot.values()],
        [contacts[f.side] for f in all_phases[0].stance],
        opts.qp,
    )
    corners = np.array(
        [
            [sx * opts.sole_half_length, sy * opts.sole_half_width, 0.0]
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
    )
    t_all, q_all, v_all, tau_all, com_all, cref_all, zmp_all, margin_all = ([] for _ in range(8))
    control_times: list[float] = []
    solves: dict[str, Any] = {}
    wrench_log: dict[str, list[FloatArray]] = {"left": [], "right": []}
    phases_done: list[tuple[str, float, float]] = []
    worst_cone = -np.inf
    q, v = q0, v0
    message = ""
    applied: list[FloatArray] = []
    height = float(np.mean(list(ground.values())))
    for index, phase in enumerate(all_phases):
        stance_sides = tuple(f.side for f in phase.stance)
        last = index == len(all_phases) - 1
        steps = round((phase.end - phase.start) / opts.dt)  # simulate_with_contacts' steps
        active = set(qp.contacts)
        for s in foot_frames:  # the contact set of this phase
            c = contacts[s]
            if s in stance_sides and c not in active:
                qp.add_contact(c)  # touchdown (its bound: see _TouchdownRamp)
            elif s not in stance_sides and c in active and c.frame not in qp.releasing:
                qp.remove_contact(c.frame)  # lift-off without a transition
            weight_s = 0.0 if s in stance_sides else opts.foot_weight
            swing_pos[s].weight = weight_s
            swing_rot[s].weight = weight_s
        swing_traj = None
        if phase.kind is PhaseKind.SINGLE_SUPPORT and phase.swing is not None:
            land = phase.swing[1]
            side = land.side
            swing_traj = _swing_trajectory(phase, opts.clearance, ground[side])
            swing_rot[side].set_target(turn.foot(land))
            swing_rot[side].set_reference(np.zeros(3), np.zeros(3))
        # the pelvis turns with the feet (mean heading of the feet at the end of the phase)
        feet_end = {f.side: f for f in phase.stance}
        if phase.swing is not None:
            feet_end[phase.swing[1].side] = phase.swing[1]
        pelvis_task.set_target(turn.pelvis(feet_end.values()))
        t_phase0 = phase.start
        touchdown, lift_off = _transitions(all_phases, index, contacts, opts, weight, steps)
        for c in contacts.values():
            c.max_normal_force = None
        control = _PhaseControl(
            qp,
            state,
            com_task,
            com_reference,
            t_phase0,
            opts.dt,
            steps + 1 if last else steps,
            swing_traj,
            swing_pos,
            control_times,
            touchdown,
            lift_off,
            solves,
            applied,
        )
        roll = simulate_with_contacts(
            robot,
            control,
            q,
            v,
            phase.end - phase.start,
            opts.dt,
            [contacts[s] for s in stance_sides],
        )
        # the last sample of a phase is the next phase's first (same state; its torque is
        # computed and applied there): kept only at the end of the walk
        keep = len(roll.t) if last else len(roll.t) - 1
        phases_done.append((phase.kind.value, phase.start, phase.end))
        for side in ("left", "right"):
            frame = foot_frames[side]
            wrench_log[side].append(
                roll.forces[frame][:keep] if side in stance_sides else np.zeros((keep, 6))
            )
        for s in stance_sides:  # the cones the controller gave the QP
            K, k_min = contacts[s].cone()
            f = roll.forces[foot_frames[s]][:keep]
            bound = k_min - f.dot(K.T)
            if lift_off is not None and lift_off.frame == foot_frames[s]:
                # released: its minimum normal force is 0 from the transition's first step
                normal = np.all(K == np.eye(K.shape[1])[2], axis=1) & (k_min > 0)
                bound[lift_off.start :, normal] -= k_min[normal]
            worst_cone = max(worst_cone, float(bound.max(initial=-np.inf)))
        for k in range(keep):
            wrenches = []
            pts = []
            for s in stance_sides:
                frame = foot_frames[s]
                M = robot.frame_placement(roll.q[k], frame)
                wrenches.append(ContactWrench.from_local(M, roll.forces[frame][k]))
                pts.append(corners @ M.rotation.T + M.translation)
            try:
                z = zmp_from_wrenches(wrenches, height=height)[:2]
            except InvalidInputError:
                z = np.full(2, np.nan)
            zmp_all.append(z)
            margin_all.append(SupportPolygon.from_points(np.vstack(pts)).margin(z))
            cref_all.append(com_reference(t_phase0 + roll.t[k])[0])
        t_all.append(t_phase0 + roll.t[:keep])
        q_all.append(roll.q[:keep])
        v_all.append(roll.v[:keep])
        tau_all.append(roll.tau[:keep])
        com_all.append(roll.com[:keep])
        q, v = roll.q[-1], roll.v[-1]
        if not np.isfinite(q).all() or roll.com[-1, 2] < 0.5 * c0[2]:
            message = (
                f"the robot fell during the {phase.kind.value} phase at t = {phase.start:.2f} s"
            )
            break
    for c in contacts.values():
        c.max_normal_force = None
    solves["contact_changes"] = qp.contacts_version
    margins = np.array(margin_all)
    ok = (
        not message
        and worst_cone <= 1e-6
        and bool(np.all(np.isfinite(margins)))
        and float(margins.min()) >= -1e-6
    )
    return WalkingResult(
        success=ok,
        times=np.concatenate(t_all),
        q=np.vstack(q_all),
        v=np.vstack(v_all),
        tau=np.vstack(tau_all),
        com=np.vstack(com_all),
        com_reference=np.array(cref_all),
        zmp=np.array(zmp_all),
        zmp_margin=margins,
        cone_violation=float(worst_cone),
        phases=phases_done,
        wrenches={side: np.vstack(w) for side, w in wrench_log.items()},
        control_times=np.array(control_times),
        message=message,
        solves=solves,
    )


def _transitions(
    phases: list[Any],
    index: int,
    contacts: Mapping[str, Contact],
    opts: WalkingOptions,
    weight: float,
    steps: int,
) -> tuple[_TouchdownRamp | None, _LiftOff | None]:
    """The force transitions of double-support phase ``index`` (``steps`` control steps).

    Up for a foot that landed at its start, down (a removal with a transition) for a foot that
    lifts at its end: its last transition step is the phase's last applied step.
    """
    phase = phases[index]
    if opts.transition_time <= 0 or phase.kind is not PhaseKind.DOUBLE_SUPPORT or steps < 1:
        return None, None
    n = max(1, min(steps, round(opts.transition_time / opts.dt)))
    before = phases[index - 1] if index > 0 else None
    after = phases[index + 1] if index + 1 < len(phases) else None
    touchdown = lift_off = None
    if before is not None and before.swing is not None:
        touchdown = _TouchdownRamp(contacts[before.swing[1].side], n * opts.dt, weight)
    if after is not None and after.swing is not None:
        frame = contacts[after.swing[1].side].frame
        lift_off = _LiftOff(frame, steps - n, n, opts.dt)
    return touchdown, lift_off
