"""ZMP MPC: the precomputed step builder against the per-step builder it replaced.

Reference: ``_reference_build`` below is the builder as it was before the precomputation (the
condensed cart-table prediction ``xt_k = Phi_k xt_0 + sum_i Gam_{k,i} du_i + Psi_{k,i} dr_{i+1}``
evaluated per axis, the linear term ``Gam^T W x_free``, the polygon rows ``A_k[:, a] e_k``
written one polygon at a time). The closed loop is run with it and a separate QP solver, and
every step's QP data, every solution and the ZMP trajectory are compared with ZmpMpc's.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.locomotion.footsteps import StepTiming, arc_walk, straight_walk
from taskspace.locomotion.lipm import CartTable
from taskspace.locomotion.support_polygon import SupportPolygon
from taskspace.locomotion.zmp_mpc import MAX_EDGES, ZmpMpc, ZmpMpcOptions
from taskspace.locomotion.zmp_reference import support_polygons, zmp_reference
from taskspace.qp import INF, QPProblem, QPSolver


def _reference_build(mpc: ZmpMpc, xt, reference, polygons) -> QPProblem:
    N = mpc.horizon
    dr = np.diff(reference, axis=0)
    g = np.empty(2 * N)
    free = np.empty((N, 2))
    for a in range(2):
        x_free = mpc._Phi @ xt[:, a] + mpc._Psi @ dr[:, a]  # (N, 4)
        g[a * N : (a + 1) * N] = mpc._Gam.reshape(N * 4, N).T @ mpc._Wb @ x_free.ravel()
        free[:, a] = x_free[:, 0]
    problem = QPProblem.unconstrained(mpc._H, g)
    if polygons is None:
        return problem
    rows = N * MAX_EDGES
    C = np.zeros((rows, 2 * N))
    u = np.full(rows, INF)
    for k, poly in enumerate(polygons):
        Ah, bh = poly.halfspaces()
        m = Ah.shape[0]
        r0 = k * MAX_EDGES
        e_row = mpc._Gam[k, 0, :]
        C[r0 : r0 + m, :N] = np.outer(Ah[:, 0], e_row)
        C[r0 : r0 + m, N:] = np.outer(Ah[:, 1], e_row)
        u[r0 : r0 + m] = bh - mpc.options.zmp_margin - Ah @ (free[k] + reference[k + 1])
    problem.C, problem.l, problem.u = C, np.full(rows, -INF), u
    return problem


def _assert_same(new: QPProblem, old: QPProblem) -> None:
    np.testing.assert_array_equal(new.H, old.H)
    scale = max(1.0, np.abs(old.g).max())
    np.testing.assert_allclose(new.g, old.g, rtol=0, atol=1e-12 * scale)
    assert new.C.shape == old.C.shape
    np.testing.assert_allclose(new.C, old.C, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(new.l, old.l)
    np.testing.assert_allclose(new.u, old.u, rtol=0, atol=1e-12)


def _walk(mpc: ZmpMpc, ref, polys, x0=None):
    """The closed loop of ZmpMpc.simulate with the reference builder; checks every step."""
    res = mpc.simulate(ref, polys, x0)
    T, N = ref.shape[0], mpc.horizon
    padded = np.vstack([ref, np.repeat(ref[-1:], N + 1, axis=0)])
    pad_polys = list(polys) + [polys[-1]] * (N + 1) if polys is not None else None
    x = np.zeros((3, 2)) if x0 is None else np.array(x0, dtype=float)
    if x0 is None:
        x[0] = ref[0]
    A, B, c = mpc.model.A, mpc.model.B[:, 0], mpc.model.C[0]
    x_prev, u = x.copy(), np.zeros(2)
    solver = QPSolver(mpc.options.qp)
    zmp = np.empty((T, 2))
    statuses = []
    cond = np.linalg.cond(mpc._H)
    for k in range(T):
        xt = np.vstack([c @ x - ref[k], x - x_prev])
        window = pad_polys[k + 1 : k + N + 1] if pad_polys is not None else None
        old = _reference_build(mpc, xt, padded[k : k + N + 1], window)
        _assert_same(mpc.build(xt, padded[k : k + N + 1], window), old)
        sol = solver.solve(old)
        statuses.append(sol.status)
        # the same (cold) solver on the new and the reference data: H's condition number
        # (4e7 here) turns the 1e-16 rounding differences of g into ~1e-10 in du, so du is
        # compared at that bound and the predicted ZMP it gives (E du) to 1e-10
        x_new = QPSolver(mpc.options.qp).solve(mpc.build(xt, padded[k : k + N + 1], window)).x
        x_old = QPSolver(mpc.options.qp).solve(old).x
        bound = 1e-15 * cond * max(1.0, np.abs(x_old).max())
        np.testing.assert_allclose(x_new, x_old, rtol=0, atol=bound)
        e_new = x_new.reshape(2, N) @ mpc._Gam[:, 0, :].T
        e_old = x_old.reshape(2, N) @ mpc._Gam[:, 0, :].T
        np.testing.assert_allclose(e_new, e_old, rtol=0, atol=1e-10)
        u = u + np.array([sol.x[0], sol.x[N]])
        zmp[k] = c @ x
        x_prev = x
        x = A @ x + np.outer(B, u)
    np.testing.assert_allclose(res.trajectory.zmp, zmp, rtol=0, atol=1e-9)
    assert res.statuses == statuses  # the unconstrained shortcut where QPSolver takes it
    return res


def test_step_data_equal_reference_over_a_turning_walk():
    model = CartTable(com_height=0.8, dt=0.05)
    plan = arc_walk(4, radius=1.0, angle=0.6, timing=StepTiming(single_support=0.6))
    times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
    mpc = ZmpMpc(model, ZmpMpcOptions(zmp_margin=0.01))
    res = _walk(mpc, zmp_reference(plan, times), support_polygons(plan, times))
    assert res.success


def test_step_data_equal_reference_with_active_constraints_and_unconstrained():
    model = CartTable(com_height=0.8, dt=0.05)
    T = 30
    ref = np.zeros((T, 2))
    poly = SupportPolygon.from_points([[-0.1, -0.15], [0.1, -0.15], [0.1, 0.15], [-0.1, 0.15]])
    x0 = np.zeros((3, 2))
    x0[1] = (0.25, -0.1)  # a push: the ZMP is held on the edge for a while
    res = _walk(ZmpMpc(model), ref, [poly] * T, x0)
    assert res.active_steps > 0
    plan = straight_walk(3)
    times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
    _walk(ZmpMpc(model, ZmpMpcOptions(constrain_zmp=False)), zmp_reference(plan, times), None)


def test_build_errors():
    mpc = ZmpMpc(CartTable(dt=0.1))
    N = mpc.horizon
    line = SupportPolygon.from_points([[0, 0], [1, 0]])
    with pytest.raises(Exception, match="no interior"):
        mpc.build(np.zeros((4, 2)), np.zeros((N + 1, 2)), [line] * N)
