"""Simulation of a robot held by rigid contacts, to run inverse-dynamics controllers.

Forward dynamics with bilateral rigid contacts through Pinocchio's ``constraintDynamics``
(contact forces as Lagrange multipliers, Baumgarte stabilization), semi-implicit Euler on the
configuration manifold. A contact is 6-D (a flat foot welded to the ground: wrench in the
contact frame) or 3-D (a point foot: force in world-aligned axes, free to rotate). Contacts
are bilateral in the simulator: the rollout records the simulated contact forces and, for
contacts given as :class:`~taskspace.constraints.contact.Contact` objects, checks them against
their linearized friction cones ``K f >= k`` (a foot that would lift or slip shows up as a
violation in ``ContactRollout.cone_violations``, or as a :class:`ContactViolationError` with
``raise_on_violation``).

Thread safety: :func:`simulate_with_contacts` keeps its state local to the call and steps the given
controller (an :class:`InverseDynamicsQP` serializes its calls); a :class:`ContactRollout` is plain
result data (arrays), not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_positive
from taskspace.constraints.contact import Contact, PointContact
from taskspace.dynamics.simulation import SimulationDivergedError, check_record_size
from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.model.robot import Robot

__all__ = [
    "ContactRollout",
    "ContactViolationError",
    "Controller",
    "SimulationDivergedError",
    "simulate_with_contacts",
]

MAX_VELOCITY = 1e3
"""Default bound of :func:`simulate_with_contacts` on ``|v|_inf`` [rad/s, m/s]: beyond it the
state is declared diverged (no joint of a robot held by contacts moves at 1000 rad/s)."""


class ContactViolationError(TaskspaceError):
    """A simulated contact force left its friction cone (the foot would lift or slip).

    Attributes:
        rollout: the rollout up to and including the offending step.
        contact: frame name of the contact.
        time: time of the violation [s].
        violation: largest ``k - K f`` at that time [N].
    """

    def __init__(self, rollout: ContactRollout, contact: str, time: float, violation: float):
        super().__init__(
            f"contact '{contact}' left its friction cone at t = {time:.3f} s by {violation:.3g} N "
            "(the foot would lift or slip): lower the task gains, raise the friction "
            "coefficient or the contacts' min_force, or pass raise_on_violation=False to "
            "record the violations in ContactRollout.cone_violations"
        )
        self.rollout = rollout
        self.contact = contact
        self.time = time
        self.violation = violation


Controller = Callable[[float, FloatArray, FloatArray], FloatArray]
"""``tau = controller(t, q, v)`` (size nv)."""

_max = np.maximum.reduce


@dataclass
class ContactRollout:
    """Recorded rollout.

    Attributes:
        t: times (N,) [s].
        q: configurations (N, nq).
        v: velocities (N, nv).
        tau: applied torques (N, nv).
        forces: per contact frame, simulated forces: (N, 6) wrenches in the contact frame
            for 6-D contacts, (N, 3) forces in world-aligned axes for point contacts [N, N m].
        com: center of mass (N, 3) [m].
        cone_violations: per contact given as a ``Contact``, the largest violation of its
            cone ``max_t max(k - K f(t))`` [N] (<= 0 when the forces stay inside).
    """

    t: FloatArray
    q: FloatArray
    v: FloatArray
    tau: FloatArray
    forces: dict[str, FloatArray] = field(default_factory=dict)
    com: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    cone_violations: dict[str, float] = field(default_factory=dict)

    @property
    def inside_cones(self) -> bool:
        """Whether every checked contact force stayed inside its cone (to 1e-6 N)."""
        return all(v <= 1e-6 for v in self.cone_violations.values())


def simulate_with_contacts(
    robot: Robot,
    controller: Controller,
    q0: Any,
    v0: Any,
    duration: float,
    dt: float,
    contact_frames: Sequence[str | Contact],
    *,
    baumgarte: tuple[float, float] = (0.0, 20.0),
    raise_on_violation: bool = False,
    max_velocity: float = MAX_VELOCITY,
) -> ContactRollout:
    """Simulate ``duration`` [s] with rigid contacts at ``contact_frames``.

    Args:
        robot: the robot.
        controller: ``tau = controller(t, q, v)``.
        q0, v0: initial state.
        duration: simulated time [s].
        dt: time step [s].
        contact_frames: the contacts, anchored where they start: a frame name (a 6-D
            contact), or a :class:`~taskspace.constraints.contact.Contact` (a
            :class:`~taskspace.constraints.contact.PointContact` is simulated as a 3-D point
            contact, any other as 6-D), whose friction cone is then checked at every step.
        baumgarte: (Kp, Kd) of the contact drift stabilization (finite, >= 0) [1/s^2, 1/s].
        raise_on_violation: raise :class:`ContactViolationError` as soon as a checked contact
            force leaves its cone by more than 1e-6 N (default: record it in
            ``ContactRollout.cone_violations``).
        max_velocity: divergence bound on ``|v|_inf`` [rad/s, m/s] (default
            :data:`MAX_VELOCITY`; ``inf`` checks finiteness only).

    Raises:
        SimulationDivergedError: the state diverged: ``q``, ``v``, the acceleration or a
            contact force is not finite, or ``|v|_inf > max_velocity``; it carries the time,
            the step index, what diverged and the rollout up to the last sound sample (the
            integration stops there: no NaN trajectory is returned).
        InvalidInputError: bad arguments; a controller torque of the wrong shape or not
            finite; a record that would not fit in half the available memory.
    """
    check_positive(duration, "duration")
    check_positive(dt, "dt")
    if dt > duration:  # round(duration / dt) = 0 steps: one sample, silently
        raise InvalidInputError(f"dt must not exceed duration, got dt={dt} > duration={duration}")
    try:
        kp_b, kd_b = (float(g) for g in baumgarte)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"baumgarte must be two numbers (Kp, Kd), got {baumgarte!r}"
        ) from None
    if not (math.isfinite(kp_b) and math.isfinite(kd_b) and kp_b >= 0.0 and kd_b >= 0.0):
        # NaN was reported as a diverged simulation; negative gains make the drift grow
        raise InvalidInputError(
            f"baumgarte gains (Kp, Kd) must be finite and >= 0, got {tuple(baumgarte)!r}"
        )
    if not (isinstance(max_velocity, int | float) and max_velocity > 0):  # inf: no bound
        raise InvalidInputError(f"max_velocity must be > 0 (inf: no bound), got {max_velocity!r}")
    model = robot._model
    data = model.createData()
    q = robot.check_configuration(q0, "q0")
    v = robot.check_velocity(v0, "v0")
    contacts: list[tuple[str, Contact | None]] = []
    for item in contact_frames:
        if isinstance(item, Contact):
            if item.robot is not robot:
                raise InvalidInputError(f"contact '{item.name}' is defined on another robot")
            contacts.append((item.frame, item))
        elif isinstance(item, str):
            contacts.append((item, None))
        else:
            raise InvalidInputError(
                "contact_frames takes frame names (6-D contacts) or Contact objects "
                f"(Contact6D, PointContact), got {type(item).__name__}"
            )
    names = [name for name, _ in contacts]
    if len(set(names)) != len(names):
        raise InvalidInputError(f"a frame is held by two contacts: {names}")
    pin.framesForwardKinematics(model, data, q)
    models = []
    dims = []
    for name, contact in contacts:
        fid = robot.frame_id(name)
        frame = model.frames[fid]
        point = isinstance(contact, PointContact)
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_3D if point else pin.ContactType.CONTACT_6D,
            model,
            frame.parentJoint,
            frame.placement,
            0,
            data.oMf[fid],
            pin.LOCAL_WORLD_ALIGNED if point else pin.LOCAL,
        )
        params = cm.m_baumgarte_parameters
        params.Kp = kp_b
        params.Kd = kd_b
        cm.setBaumgarteCorrectorParameters(params)
        models.append(cm)
        dims.append(3 if point else 6)
    cmodels = pin.StdVec_RigidConstraintModel()
    for cm in models:
        cmodels.append(cm)
    cdatas = pin.StdVec_RigidConstraintData()
    for cm in models:
        cdatas.append(cm.createData())
    pin.initConstraintDynamics(model, data, cmodels, cdatas)
    settings = pin.ProximalSettings(1e-12, 1e-12, 10)
    steps = round(duration / dt)
    check_record_size(
        steps, model.nq, model.nv, duration, dt, name="simulate_with_contacts", extra=sum(dims)
    )
    ts = np.arange(steps + 1, dtype=np.float64) * float(dt)
    Q = np.zeros((steps + 1, model.nq))
    V = np.zeros((steps + 1, model.nv))
    TAU = np.zeros((steps + 1, model.nv))
    F = {name: np.zeros((steps + 1, d)) for name, d in zip(names, dims)}
    COM = np.zeros((steps + 1, 3))
    offsets = np.concatenate([[0], np.cumsum(dims)]).astype(int)
    cones = {name: c.cone() for name, c in contacts if c is not None}
    worst = {name: -np.inf for name in cones}

    def partial(k: int) -> ContactRollout:
        """The rollout of samples ``0..k-1``."""
        return ContactRollout(
            ts[:k],
            Q[:k],
            V[:k],
            TAU[:k],
            {n: f[:k] for n, f in F.items()},
            COM[:k],
            dict(worst),
        )

    def diverged(k: int, quantity: str, value: float, bound: float = math.inf) -> None:
        raise SimulationDivergedError(
            quantity,
            float(ts[k]),
            k,
            value,
            bound,
            partial(k),
            "the controller or the contacts drive the robot unstable (lower the gains or dt, "
            "check the contacts can hold the robot)",
        )

    for k in range(steps + 1):
        # guard rails, once per step: q and v finite, |v| bounded (a diverging state is
        # stopped here, before the controller builds a QP from it)
        vmax = float(_max(np.abs(v))) if model.nv else 0.0
        if not vmax <= max_velocity:
            diverged(k, "v", vmax, max_velocity)
        if not math.isfinite(float(q.dot(q))):
            diverged(k, "q", math.nan)
        tau = np.asarray(controller(float(ts[k]), q, v), dtype=float)
        if tau.shape != (model.nv,) or not np.all(np.isfinite(tau)):
            raise InvalidInputError(
                f"controller returned torques of shape {tau.shape} or non-finite at t={ts[k]:.3f}"
            )
        a = pin.constraintDynamics(model, data, q, v, tau, cmodels, cdatas, settings)
        lam = np.asarray(data.lambda_c)
        amax = float(_max(np.abs(a))) if model.nv else 0.0
        if not math.isfinite(amax):
            diverged(k, "a", amax)
        if lam.size and not math.isfinite(float(_max(np.abs(lam)))):
            diverged(k, "contact forces", math.nan)
        Q[k], V[k], TAU[k] = q, v, tau
        for i, name in enumerate(names):
            F[name][k] = lam[offsets[i] : offsets[i + 1]]
        COM[k] = pin.centerOfMass(model, data, q, False)
        for name, (K, kk) in cones.items():
            violation = float((kk - K.dot(F[name][k])).max())
            worst[name] = max(worst[name], violation)
            if raise_on_violation and violation > 1e-6:
                raise ContactViolationError(partial(k + 1), name, float(ts[k]), violation)
        if k < steps:
            v = v + dt * np.asarray(a)
            q = pin.integrate(model, q, v * dt)
    return ContactRollout(ts, Q, V, TAU, F, COM, worst)
