"""ZMP MPC: every step's KKT residuals, checked against independent solves.

References: quadprog (Goldfarb-Idnani, a dual active-set method, not one of ZmpMpc's paths)
on every step's QP of a closed loop whose ZMP is held on the polygon's edge; the analytic
preview control law (:class:`PreviewController`, Riccati gains) when no constraint is active.
The contract checked: a solved step (``SOLVED`` or ``UNCONSTRAINED``) carries residuals within
``eps_abs + eps_rel * scale`` of the QP options, and its applied input is quadprog's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import quadprog

from taskspace.locomotion.footsteps import straight_walk
from taskspace.locomotion.lipm import CartTable
from taskspace.locomotion.preview_control import PreviewController
from taskspace.locomotion.support_polygon import SupportPolygon
from taskspace.locomotion.zmp_mpc import ZmpMpc, ZmpMpcOptions
from taskspace.locomotion.zmp_reference import zmp_reference
from taskspace.qp import QPStatus


def _within(mpc: ZmpMpc, res) -> None:  # type: ignore[no-untyped-def]
    opts = mpc.options.qp
    assert len(res.kkt) == len(res.statuses) == res.trajectory.times.size
    for status, kkt in zip(res.statuses, res.kkt):
        assert status in (QPStatus.SOLVED, QPStatus.UNCONSTRAINED)
        assert kkt.within(opts.eps_abs, opts.eps_rel), kkt
    worst = res.max_kkt
    assert all(np.isfinite(v) and v <= 1e-9 for v in worst.values()), worst


def test_each_step_is_quadprogs_with_residuals_within_tolerance():
    model = CartTable(com_height=0.8, dt=0.05)
    T = 30
    ref = np.zeros((T, 2))
    poly = SupportPolygon.from_points([[-0.1, -0.15], [0.1, -0.15], [0.1, 0.15], [-0.1, 0.15]])
    x0 = np.zeros((3, 2))
    x0[1] = (0.25, -0.1)  # a push: the ZMP is held on the edge for a while
    mpc = ZmpMpc(model)
    calls = []
    solve = mpc._solver.solve
    mpc._solver.solve = lambda p: calls.append(1) or solve(p)  # type: ignore[method-assign]
    res = mpc.simulate(ref, [poly] * T, x0)
    _within(mpc, res)
    statuses = [s.value for s in res.statuses]
    assert set(statuses) == {"solved", "unconstrained"} and res.active_steps > 3
    # the unconstrained steps took the shortcut (its residuals met the tolerances)
    assert len(calls) == statuses.count("solved")
    # replay: every step's QP (from the closed loop's own states) solved by quadprog
    N = mpc.horizon
    tr = res.trajectory
    states = np.stack([tr.com, tr.com_velocity, tr.com_acceleration], axis=1)  # (T, 3, 2)
    padded = np.vstack([ref, np.repeat(ref[-1:], N + 1, axis=0)])
    c = model.C[0]
    previous_u = np.zeros(2)
    for k in range(T):
        x_prev = states[k - 1] if k else states[0]
        xt = np.vstack([c @ states[k] - ref[k], states[k] - x_prev])
        p = mpc.build(xt, padded[k : k + N + 1], [poly] * N)
        rows = np.isfinite(p.u)
        x, *_ = quadprog.solve_qp(p.H, -p.g, -p.C[rows].T, -p.u[rows], 0)
        du = np.array([x[0], x[N]])
        applied = tr.jerk[k] - previous_u
        previous_u = tr.jerk[k]
        # H's condition number (~4e7) scales rounding in g up to ~1e-9 relative in du
        assert applied == pytest.approx(du, abs=1e-7 * max(1.0, np.abs(du).max()))


def test_unconstrained_steps_are_the_preview_law():
    model = CartTable(com_height=0.8, dt=0.05)
    plan = straight_walk(3)
    times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
    ref = zmp_reference(plan, times)
    mpc = ZmpMpc(model, ZmpMpcOptions(constrain_zmp=False))
    init = np.zeros((3, 2))
    init[0] = ref[0]
    res = mpc.simulate(ref, None, init)
    _within(mpc, res)
    assert all(s is QPStatus.UNCONSTRAINED for s in res.statuses)
    law = PreviewController(model, mpc.options.preview).simulate(ref, init)
    T = ref.shape[0]
    assert res.trajectory.com == pytest.approx(law.com[:T], abs=1e-9)
    assert res.trajectory.zmp == pytest.approx(law.zmp[:T], abs=1e-9)


def test_a_shortcut_missing_the_tolerances_goes_to_the_qp_solver(monkeypatch):
    """The shortcut's residuals are checked for all steps at the end of a run; a step that
    misses the tolerances (here: made to, by inflating its dual residual) makes the run start
    again with each step checked, and that step alone is solved by the QP solver."""
    model = CartTable(com_height=0.8, dt=0.05)
    plan = straight_walk(2)
    times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
    ref = zmp_reference(plan, times)
    mpc = ZmpMpc(model, ZmpMpcOptions(constrain_zmp=False))
    plain = mpc.simulate(ref)
    residuals = mpc._shortcut_residuals
    per_step = []

    def inflated(X, G, v):  # type: ignore[no-untyped-def]
        out = residuals(X, G, v)
        if len(out) > 1:  # the batch at the end of the first run: step 3 misses
            out[3] = dataclasses.replace(out[3], dual=1.0)
        else:  # the run with each step checked
            per_step.append(1)
            if len(per_step) == 4:
                out[0] = dataclasses.replace(out[0], dual=1.0)
        return out

    monkeypatch.setattr(mpc, "_shortcut_residuals", inflated)
    calls = []
    solve = mpc._solver.solve
    monkeypatch.setattr(mpc._solver, "solve", lambda p: calls.append(1) or solve(p))
    res = mpc.simulate(ref)
    assert len(calls) == 1 and len(per_step) == len(ref)  # step 3 by the QP solver
    _within(mpc, res)
    assert res.trajectory.zmp == pytest.approx(plain.trajectory.zmp, abs=1e-9)
