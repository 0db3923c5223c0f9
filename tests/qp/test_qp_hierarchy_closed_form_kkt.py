"""Closed-form cascade levels: the step is the undamped least-norm minimizer, and its KKT
residuals are those of the problem it solves.

The equality cascade of :class:`HierarchySolver` solves a well-conditioned level by QR: the
least-norm minimizer of ``|JZ z - res|^2`` (damping 0, the limit of the damped minimizer). Its
residuals used to be evaluated against the damped problem (``mu = 1e-9``), whose dual residual
is ``mu |z|``: on the standing G1 inverse-dynamics hierarchy the CoM level (``|z| = 78``, the
singular values of ``JZ`` 0.02-0.03) failed ``kkt.within(1e-9, 1e-6)`` by 2x although its answer
is exact. References: NumPy's SVD least squares (``lstsq``, orthonormal nullspaces by
``scipy.linalg.null_space``) for the cascade's point, quadprog on the damped level QP for the
size of the damping's effect (``mu / s_min^2`` relative).
"""

from __future__ import annotations

import numpy as np
import pytest
import quadprog
from scipy.linalg import null_space

import taskspace.qp.hierarchy as hierarchy
from taskspace.qp.hierarchy import HierarchyLevel, HierarchySolver
from taskspace.qp.result import QPStatus


def _lexicographic(levels, A, b):  # type: ignore[no-untyped-def]
    """Least-norm lexicographic least squares, by SVDs (independent of the solver's QRs)."""
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    N = null_space(A)
    for level in levels:
        JN = level.J @ N
        x = x + N @ np.linalg.lstsq(JN, level.r - level.J @ x, rcond=None)[0]
        N = N @ null_space(JN, rcond=1e-10) if JN.size else N
    return x


def test_small_singular_values_closed_form_level_is_exact_and_certified():
    rng = np.random.default_rng(3)
    n = 30
    A = rng.standard_normal((6, n))  # hard equalities (dynamics-like)
    b = rng.standard_normal(6)
    # a first level with small singular values (0.02-0.03) and a large step (|z| ~ 100)
    U, _, Vt = np.linalg.svd(rng.standard_normal((3, n)), full_matrices=False)
    J0 = U @ np.diag([0.03, 0.025, 0.02]) @ Vt
    levels = [
        HierarchyLevel("small rows", J0, np.array([2.0, -1.5, 1.0])),
        HierarchyLevel("posture", np.eye(n), rng.standard_normal(n)),
    ]
    captured = []
    kkt = hierarchy.least_squares_kkt_residuals

    def spy(JZ, res, z, mu, primal):  # type: ignore[no-untyped-def]
        captured.append((JZ.copy(), res.copy(), z.copy(), mu))
        return kkt(JZ, res, z, mu, primal)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(hierarchy, "least_squares_kkt_residuals", spy)
        result = HierarchySolver().solve(levels, n, A=A, b=b)
        assert result.status is QPStatus.UNCONSTRAINED
        assert all(r.backend == "closed form" for r in result.level_results)
        for r in result.level_results:
            assert r.kkt.within(1e-9, 1e-6), r.kkt  # failed for the first level before
    # the answer: the independent lexicographic least squares
    x = _lexicographic(levels, A, b)
    assert result.x == pytest.approx(x, abs=1e-9 * max(1.0, np.abs(x).max()))
    # the first level's step vs quadprog on the damped level QP: they differ by the damping's
    # effect only, about mu / s_min^2 relative (here ~2.5e-6)
    JZ, res, z, mu = captured[0]
    assert mu == 0.0 and np.abs(z).max() > 50
    damping = HierarchySolver().options.damping
    H = JZ.T @ JZ + damping * np.eye(JZ.shape[1])
    zq = quadprog.solve_qp(H, JZ.T @ res)[0]
    s_min = np.linalg.svd(JZ, compute_uv=False).min()
    gap = np.abs(zq - z).max() / np.abs(z).max()
    assert gap <= 10 * damping / s_min**2
    # and the undamped step leaves no task residual where the damped one does
    assert np.linalg.norm(JZ @ z - res) < 1e-12 < np.linalg.norm(JZ @ zq - res)


def test_standing_g1_inverse_dynamics_hierarchy_levels_are_certified(robot_loader):
    """The scene where the failure was seen: every closed-form level within (1e-9, 1e-6)."""
    from taskspace import features as F
    from taskspace.constraints import Contact6D
    from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP
    from taskspace.tasks import Task

    robot = robot_loader("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ("left_ankle_roll_link", "right_ankle_roll_link")
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in feet]
    com = Task(F.CenterOfMass(robot), kp=40.0, priority=0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=1)
    options = InverseDynamicsOptions(hierarchical=True)
    res = InverseDynamicsQP(robot, [com, posture], contacts, options).solve(s)
    assert [r.backend for r in res.level_results] == ["closed form"] * 3
    for r in res.level_results:
        assert r.kkt.within(1e-9, 1e-6), r.kkt
