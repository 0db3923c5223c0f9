"""Cart-table model, Kajita's preview controller and the ZMP MPC.

References: the matrix exponential of the continuous triple integrator; a batch least-squares
solution of the finite-horizon LQ problem (long horizon, no terminal cost); the published
behaviour of preview control (small ZMP error, the CoM moves before the ZMP reference); the
support polygon for the constrained MPC.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from taskspace.errors import InvalidInputError, ShapeError
from taskspace.locomotion.footsteps import StepTiming, straight_walk
from taskspace.locomotion.lipm import CartTable
from taskspace.locomotion.preview_control import (
    PreviewController,
    PreviewOptions,
    preview_walking_pattern,
)
from taskspace.locomotion.support_polygon import SupportPolygon
from taskspace.locomotion.zmp_mpc import ZmpMpc, ZmpMpcOptions, mpc_walking_pattern
from taskspace.locomotion.zmp_reference import support_polygons
from taskspace.qp import QPStatus


def test_cart_table_is_exact_discretization():
    m = CartTable(com_height=0.814, dt=0.01)
    Ac = np.diag([1.0, 1.0], k=1)
    Bc = np.array([[0.0], [0.0], [1.0]])
    big = sla.expm(np.block([[Ac, Bc], [np.zeros((1, 4))]]) * m.dt)
    assert m.A == pytest.approx(big[:3, :3], abs=1e-14)
    assert m.B == pytest.approx(big[:3, 3:], abs=1e-14)
    assert m.zmp(np.array([0.1, 0.0, 9.81])) == pytest.approx(0.1 - 0.814)


def _batch_first_increments(model, options, cases, extra):
    """Minimize sum_{k=1..H} Q_e e_k^2 + R sum du_k^2 over a long horizon (no terminal cost)
    by least squares on the plain cart-table model; returns du_0 for each case ``(xt0, dr)``.

    ``x_k = x_0 + sum_{j<=k} dx_j``, ``dx_{j+1} = A dx_j + B du_j``, ``e_k = C x_k - r_k``,
    ``r_k = r_0 + sum_{j<=k} dr_j``; the start is ``x_0 = 0``, ``r_0 = -e_0``.
    """
    N = round(options.preview_time / model.dt)
    H = N + extra
    A, B, C = model.A, model.B, model.C
    g = np.zeros(H)  # e_k response to du_0 at lag k: C sum_{j<k} A^j B
    acc, power = np.zeros((3, 1)), np.eye(3)
    for m in range(H):
        acc = acc + power @ B
        power = A @ power
        g[m] = (C @ acc)[0, 0]
    G = sla.toeplitz(g, np.zeros(H))
    q, r = np.sqrt(options.error_weight), np.sqrt(options.input_weight)
    M = np.vstack([q * G, r * np.eye(H)])
    rhs = []
    for xt0, dr in cases:
        w = np.zeros(H)
        w[:N] = dr
        ref = -xt0[0] + np.cumsum(w)  # r_1 .. r_H
        x, dx = np.zeros(3), xt0[1:].copy()
        e_free = np.empty(H)
        for k in range(H):
            dx = A @ dx
            x = x + dx
            e_free[k] = C[0] @ x - ref[k]
        rhs.append(-np.concatenate([q * e_free, np.zeros(H)]))
    return np.linalg.lstsq(M, np.column_stack(rhs), rcond=None)[0][0]


@pytest.mark.parametrize("seed", [0])
def test_preview_gains_match_batch_finite_horizon_solution(seed):
    model = CartTable(com_height=0.8, dt=0.02)
    options = PreviewOptions(preview_time=1.0)
    ctrl = PreviewController(model, options)
    rng = np.random.default_rng(seed)
    zero = np.zeros(ctrl.horizon)
    cases = [(np.eye(4)[j], zero) for j in range(4)]  # the feedback gain, column by column
    cases.append((rng.normal(size=4), 0.01 * rng.normal(size=ctrl.horizon)))
    for j in (0, 7, 30):  # single preview gains
        dr = zero.copy()
        dr[j] = 1.0
        cases.append((np.zeros(4), dr))
    ref = _batch_first_increments(model, options, cases, extra=250)
    ours = [ctrl.jerk_increment(xt0, dr) for xt0, dr in cases]
    assert ours == pytest.approx(ref, rel=1e-7, abs=1e-9)
    assert -ctrl.preview_gains[[0, 7, 30]] == pytest.approx(ref[5:], rel=1e-7)


def test_kajita_gain_structure():
    ctrl = PreviewController(CartTable(com_height=0.814, dt=0.005))
    assert ctrl.riccati.residual < 1e-9
    # Kajita's form: G_p(1) = -G_i and the preview gains decay to zero over the horizon
    assert ctrl.preview_gains[0] == pytest.approx(-ctrl.integral_gain, rel=1e-9)
    assert abs(ctrl.preview_gains[-1]) < 0.01 * abs(ctrl.preview_gains).max()
    assert np.all(np.abs(np.linalg.eigvals(ctrl.closed_loop)) < 1)


def test_preview_tracks_ten_step_plan_and_com_leads():
    plan = straight_walk(10, step_length=0.2, step_width=0.2)
    pattern = preview_walking_pattern(plan, CartTable(com_height=0.8, dt=0.005))
    traj = pattern.trajectory
    assert traj.rms_zmp_error < 1e-3
    assert traj.zmp_error.max() < 5e-3
    # model identity cddot = g / z_c (c - p)
    assert traj.com_acceleration == pytest.approx(9.81 / 0.8 * (traj.com - traj.zmp), abs=1e-9)
    # the CoM starts moving toward the first stance foot (left: y > 0) before the ZMP
    # reference leaves the middle of the feet; the ZMP first moves the other way
    t_shift = plan.timing.initial_double_support - plan.timing.weight_shift
    before = traj.times < t_shift - 1e-9
    assert np.all(traj.zmp_reference[before, 1] == 0.0)
    assert traj.com[before, 1].max() > 5e-3
    assert traj.zmp[before, 1].min() < -1e-3
    # the lateral CoM swing is smaller than the ZMP's; the walk ends at rest between the feet
    mid = (traj.times > 3) & (traj.times < 8)
    assert np.ptp(traj.com[mid, 1]) < 0.7 * np.ptp(traj.zmp_reference[mid, 1])
    left, right = plan.final_feet()
    assert traj.com[-1] == pytest.approx(0.5 * (left.position + right.position), abs=1e-3)
    assert np.abs(traj.com_velocity[-1]).max() < 1e-3
    # the forward CoM position is monotone (no walking backwards)
    assert np.all(np.diff(traj.com[:, 0]) > -1e-6)


def test_preview_controller_input_errors():
    ctrl = PreviewController(CartTable(dt=0.05))
    with pytest.raises(InvalidInputError, match=r"\(T, 2\)"):
        ctrl.simulate(np.zeros((5, 3)))
    with pytest.raises(ShapeError):
        ctrl.simulate(np.zeros((5, 2)), initial_state=np.zeros(3))
    with pytest.raises(ShapeError):
        ctrl.jerk_increment(np.zeros(4), np.zeros(3))
    with pytest.raises(InvalidInputError, match="> 0"):
        PreviewOptions(input_weight=0.0)


def test_mpc_equals_preview_when_constraints_inactive():
    model = CartTable(com_height=0.8, dt=0.05)
    plan = straight_walk(4, timing=StepTiming(single_support=0.6, double_support=0.2))
    mpc_pattern, res = mpc_walking_pattern(plan, model)
    assert res.success and res.active_steps == 0
    preview = preview_walking_pattern(plan, model).trajectory
    assert mpc_pattern.trajectory.com == pytest.approx(preview.com, abs=1e-9)
    assert mpc_pattern.trajectory.zmp == pytest.approx(preview.zmp, abs=1e-9)
    polys = support_polygons(plan, preview.times)
    assert min(p.margin(z) for p, z in zip(polys, preview.zmp, strict=True)) > 0


def test_mpc_keeps_zmp_in_polygon_where_preview_leaves_it():
    model = CartTable(com_height=0.8, dt=0.05)
    T = 50
    ref = np.zeros((T, 2))
    poly = SupportPolygon.from_points([[-0.1, -0.15], [0.1, -0.15], [0.1, 0.15], [-0.1, 0.15]])
    x0 = np.zeros((3, 2))
    x0[1, 0] = 0.25  # a push: capture point 0.25 / omega = 7 cm ahead, inside the feet
    preview = PreviewController(model).simulate(ref, x0)
    assert preview.zmp[:, 0].max() > 0.12
    res = ZmpMpc(model).simulate(ref, [poly] * T, x0)
    assert res.success and res.active_steps > 0
    assert QPStatus.SOLVED in res.statuses
    assert all(poly.margin(z) > -1e-7 for z in res.trajectory.zmp)
    assert np.abs(res.trajectory.com[-1]).max() < 2e-3  # recovered


def test_mpc_requires_polygons():
    mpc = ZmpMpc(CartTable(dt=0.1), ZmpMpcOptions())
    with pytest.raises(InvalidInputError, match="constrain_zmp"):
        mpc.simulate(np.zeros((5, 2)))
