"""Simulation of a robot held by rigid contacts, to run inverse-dynamics controllers.

Forward dynamics with bilateral rigid contacts through Pinocchio's ``constraintDynamics``
(contact forces as Lagrange multipliers, Baumgarte stabilization), semi-implicit Euler on the
configuration manifold. Contacts are bilateral in the simulator: the rollout records the
simulated contact forces so that a test can check that they stay unilateral and inside the
friction cone (a foot that would lift or slip shows up there).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import InvalidInputError
from taskspace.model.robot import Robot

Controller = Callable[[float, FloatArray, FloatArray], FloatArray]
"""``tau = controller(t, q, v)`` (size nv)."""


@dataclass
class ContactRollout:
    """Recorded rollout.

    Attributes:
        t: times (N,) [s].
        q: configurations (N, nq).
        v: velocities (N, nv).
        tau: applied torques (N, nv).
        forces: per contact frame, simulated wrenches in the contact frame (N, 6).
        com: center of mass (N, 3) [m].
    """

    t: FloatArray
    q: FloatArray
    v: FloatArray
    tau: FloatArray
    forces: dict[str, FloatArray] = field(default_factory=dict)
    com: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))


def simulate_with_contacts(
    robot: Robot,
    controller: Controller,
    q0: Any,
    v0: Any,
    duration: float,
    dt: float,
    contact_frames: Sequence[str],
    *,
    baumgarte: tuple[float, float] = (0.0, 20.0),
) -> ContactRollout:
    """Simulate ``duration`` [s] with 6-D rigid contacts at ``contact_frames``.

    Args:
        robot: the robot.
        controller: ``tau = controller(t, q, v)``.
        q0, v0: initial state.
        duration: simulated time [s].
        dt: time step [s].
        contact_frames: frames held by 6-D contacts (anchored where they start).
        baumgarte: (Kp, Kd) of the contact drift stabilization.
    """
    check_positive(duration, "duration")
    check_positive(dt, "dt")
    model = robot.model
    data = model.createData()
    q = robot.check_configuration(q0, "q0")
    v = robot.check_velocity(v0, "v0")
    pin.framesForwardKinematics(model, data, q)
    models = []
    for name in contact_frames:
        fid = robot.frame_id(name)
        frame = model.frames[fid]
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_6D,
            model,
            frame.parentJoint,
            frame.placement,
            0,
            data.oMf[fid],
            pin.LOCAL,
        )
        params = cm.m_baumgarte_parameters
        params.Kp = baumgarte[0]
        params.Kd = baumgarte[1]
        cm.setBaumgarteCorrectorParameters(params)
        models.append(cm)
    cmodels = pin.StdVec_RigidConstraintModel()
    for cm in models:
        cmodels.append(cm)
    cdatas = pin.StdVec_RigidConstraintData()
    for cm in models:
        cdatas.append(cm.createData())
    pin.initConstraintDynamics(model, data, cmodels, cdatas)
    settings = pin.ProximalSettings(1e-12, 1e-12, 10)
    steps = round(duration / dt)
    ts = np.arange(steps + 1, dtype=np.float64) * float(dt)
    Q = np.zeros((steps + 1, model.nq))
    V = np.zeros((steps + 1, model.nv))
    TAU = np.zeros((steps + 1, model.nv))
    F = {name: np.zeros((steps + 1, 6)) for name in contact_frames}
    COM = np.zeros((steps + 1, 3))
    for k in range(steps + 1):
        tau = np.asarray(controller(float(ts[k]), q, v), dtype=float)
        if tau.shape != (model.nv,) or not np.all(np.isfinite(tau)):
            raise InvalidInputError(
                f"controller returned torques of shape {tau.shape} or non-finite at t={ts[k]:.3f}"
            )
        a = pin.constraintDynamics(model, data, q, v, tau, cmodels, cdatas, settings)
        Q[k], V[k], TAU[k] = q, v, tau
        lam = np.asarray(data.lambda_c)
        for i, name in enumerate(contact_frames):
            F[name][k] = lam[6 * i : 6 * i + 6]
        COM[k] = pin.centerOfMass(model, data, q, False)
        if k < steps:
            v = v + dt * np.asarray(a)
            q = pin.integrate(model, q, v * dt)
    return ContactRollout(ts, Q, V, TAU, F, COM)
