from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.control import (
    OperationalSpaceController,
    OperationalSpaceOptions,
    operational_space_control,
)
from taskspace.dynamics import simulate
from taskspace.errors import InvalidInputError, SolverError
from taskspace.tasks import Task


def _ee_task(panda, target, kp=100.0):  # type: ignore[no-untyped-def]
    return Task(F.Position(panda, "panda_hand_tcp"), target, kp=kp)


def test_hard_task_acceleration_is_exact(panda, rng) -> None:  # type: ignore[no-untyped-def]
    # C -> inf: J a + Jdot v = y''* exactly, with a from Pinocchio's ABA applied to u*
    for _ in range(3):
        q = panda.random_configuration(rng)
        v = rng.normal(size=7)
        state = panda.state(q, v)
        task = _ee_task(panda, np.array([0.4, 0.1, 0.5]))
        res = operational_space_control(state, [task], OperationalSpaceOptions(hard_tasks=True))
        a = pin.aba(panda.model, panda.model.createData(), q, v, res.tau)
        J, rhs = task.acceleration_rows(state)
        np.testing.assert_allclose(J @ a, rhs, atol=1e-7)
        np.testing.assert_allclose(res.a, a, atol=1e-8)
        # slide 5:33 limit formula with H = h I: u = T^T (T T^T)^-1 (y''* - Jdot v + T F)
        data = panda.model.createData()
        M = pin.crba(panda.model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        T = J @ np.linalg.inv(M)
        Fq = pin.nonLinearEffects(panda.model, data, q, v)
        u_ref = T.T @ np.linalg.solve(T @ T.T, rhs + T @ Fq)
        np.testing.assert_allclose(res.tau, u_ref, atol=1e-6)


def test_weighted_stack_matches_least_squares(panda, rng) -> None:  # type: ignore[no-untyped-def]
    q = panda.random_configuration(rng)
    v = rng.normal(size=7)
    state = panda.state(q, v)
    tasks = [
        Task(F.Position(panda, "panda_hand_tcp"), np.array([0.4, 0.1, 0.5]), weight=10.0),
        Task(F.JointConfiguration(panda), panda.q_default, weight=0.01, kp=20.0),
    ]
    h = 1e-3
    res = operational_space_control(state, tasks, OperationalSpaceOptions(torque_weight=h))
    # brute force: min_u sum_i rho_i |J_i M^-1 (u - F) + Jdot_i v - y''_i*|^2 + h |u|^2
    data = panda.model.createData()
    M = pin.crba(panda.model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    Minv = np.linalg.inv(M)
    Fq = pin.nonLinearEffects(panda.model, data, q, v)
    rows, rhs = [], []
    for task in tasks:
        J, b = task.acceleration_rows(state)  # already sqrt(rho)-weighted
        rows.append(J @ Minv)
        rhs.append(b + J @ Minv @ Fq)
    A = np.vstack([*rows, np.sqrt(h) * np.eye(7)])
    y = np.concatenate([*rhs, np.zeros(7)])
    u_ref = np.linalg.lstsq(A, y, rcond=None)[0]
    np.testing.assert_allclose(res.tau, u_ref, rtol=1e-7, atol=1e-7)


def test_osc_converges_on_panda(panda) -> None:  # type: ignore[no-untyped-def]
    s0 = panda.state(panda.q_default)
    ee = F.Position(panda, "panda_hand_tcp")
    target = ee.value(s0) + np.array([0.1, -0.1, 0.05])
    tasks = [
        Task(ee, target, kp=64.0, kd=16.0),
        Task(F.JointConfiguration(panda), panda.q_default, weight=1e-3, kp=10.0),
    ]
    ctrl = OperationalSpaceController(panda, tasks)
    traj = simulate(panda, ctrl, (panda.q_default, np.zeros(7)), 2.0, 2e-3)
    data = panda.model.createData()
    fid = panda.frame_id("panda_hand_tcp")
    err = []
    for q in traj.q[::50]:
        pin.framesForwardKinematics(panda.model, data, q)
        err.append(np.linalg.norm(data.oMf[fid].translation - target))
    assert err[0] > 0.15
    assert err[-1] < 1e-3  # critically damped: ~ (1 + 8 t) exp(-8 t) 0.15 m at t = 2 s
    assert np.all(np.diff(err) < 1e-6)  # no overshoot


def test_error_paths(panda, talos) -> None:  # type: ignore[no-untyped-def]
    task = _ee_task(panda, np.zeros(3))
    with pytest.raises(InvalidInputError, match="needs the velocity"):
        operational_space_control(panda.state(panda.q_default), [task])
    with pytest.raises(InvalidInputError, match="at least one task"):
        operational_space_control(panda.state(panda.q_default, np.zeros(7)), [])
    with pytest.raises(InvalidInputError, match="floating base"):
        operational_space_control(talos.state(talos.q_default, np.zeros(talos.nv)), [task])
    msg = r"torque_weight \(H of \|u\|\^2_H\) must be finite and > 0"
    with pytest.raises(InvalidInputError, match=msg):
        operational_space_control(
            panda.state(panda.q_default, np.zeros(7)),
            [task],
            OperationalSpaceOptions(torque_weight=0.0),
        )
    # two copies of a 7-D posture task plus the ee task: 13 > 7 rows, T H^-1 T^T singular
    posture = Task(F.JointConfiguration(panda), panda.q_default)
    with pytest.raises(SolverError, match=r"T H\^-1 T\^T is singular \(rank 7 < 10"):
        operational_space_control(
            panda.state(panda.q_default, np.zeros(7)),
            [task, posture],
            OperationalSpaceOptions(hard_tasks=True),
        )
