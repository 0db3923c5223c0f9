from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace.control import StateFeedbackController, is_controllable, linearize, lqr
from taskspace.dynamics import simulate
from taskspace.errors import InvalidInputError, TaskspaceWarning, UnknownNameError

M_CART, M_POLE, L_POLE, G = 1.0, 0.1, 0.5, 9.81


def test_linearization_matches_analytic_cartpole(robot_loader) -> None:  # type: ignore[no-untyped-def]
    # point-mass pole, theta = 0 upright: x'' = (F - m g th) / M, th'' = ((M + m) g th - F) / (M l)
    robot = robot_loader("cartpole")
    sys = linearize(robot, np.zeros(2), actuated=["slider"])
    A_ref = np.zeros((4, 4))
    A_ref[0, 2] = A_ref[1, 3] = 1.0
    A_ref[2, 1] = -M_POLE * G / M_CART
    A_ref[3, 1] = (M_CART + M_POLE) * G / (M_CART * L_POLE)
    B_ref = np.array([[0.0], [0.0], [1.0 / M_CART], [-1.0 / (M_CART * L_POLE)]])
    np.testing.assert_allclose(sys.A, A_ref, atol=1e-10)
    np.testing.assert_allclose(sys.B, B_ref, atol=1e-10)
    assert is_controllable(sys.A, sys.B)
    # hinge actuated instead: B = [0; M^-1 e_2], M = [[M + m, m l], [m l, m l^2]]
    sys_h = linearize(robot, np.zeros(2), actuated=["hinge"])
    M = np.array([[M_CART + M_POLE, M_POLE * L_POLE], [M_POLE * L_POLE, M_POLE * L_POLE**2]])
    np.testing.assert_allclose(sys_h.B[2:, 0], np.linalg.inv(M)[:, 1], atol=1e-9)


def test_linearization_of_pendulum_hanging_and_upright(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("pendulum")
    down = linearize(robot, np.zeros(1))
    np.testing.assert_allclose(down.A, [[0.0, 1.0], [-G, 0.0]], atol=1e-10)  # g / l
    up = linearize(robot, np.array([np.pi]))
    np.testing.assert_allclose(up.A, [[0.0, 1.0], [G, 0.0]], atol=1e-10)
    np.testing.assert_allclose(up.B, [[0.0], [1.0]], atol=1e-12)  # 1 / (m l^2)


def test_lqr_balances_cartpole(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("cartpole")
    sys = linearize(robot, np.zeros(2), actuated=["slider"])
    design = lqr(sys.A, sys.B, np.diag([1.0, 10.0, 1.0, 1.0]), 0.1)
    assert design.stable
    ctrl = StateFeedbackController(robot, sys, design.K)
    traj = simulate(robot, ctrl, (np.array([0.0, 0.2]), np.zeros(2)), 8.0, 2e-3)
    assert traj.success
    assert np.max(np.abs(traj.q[:, 1])) < 0.25  # never falls
    assert np.all(np.abs(traj.q[-1]) < 1e-3) and np.all(np.abs(traj.v[-1]) < 1e-3)
    assert np.all(traj.tau[:, 1] == 0.0)  # the hinge is never actuated
    # without control the pole falls
    passive = simulate(robot, None, (np.array([0.0, 0.2]), np.zeros(2)), 1.0, 2e-3)
    assert abs(passive.q[-1, 1]) > 1.0


def test_error_paths(robot_loader, talos) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("cartpole")
    with pytest.raises(InvalidInputError, match="fixed-base robots only; 'talos'"):
        linearize(talos, talos.q_default)
    with pytest.raises(
        UnknownNameError, match="unknown joint 'slide'; valid joints are: hinge, slider"
    ):
        linearize(robot, np.zeros(2), actuated=["slide"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(TaskspaceWarning, match="not at an equilibrium"):
            linearize(robot, np.array([0.0, 0.3]), actuated=["slider"])
        # moving in every coordinate and accelerating: no equilibrium either (before, a v_eq
        # without a zero entry silenced the warning)
        with pytest.raises(TaskspaceWarning, match="not at an equilibrium"):
            linearize(robot, np.array([0.0, 0.3]), v_eq=np.array([0.1, 0.2]), actuated=["slider"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # upright at rest: an equilibrium, no warning
        linearize(robot, np.zeros(2), actuated=["slider"])
    sys = linearize(robot, np.zeros(2), actuated=["slider"])
    from taskspace.errors import ShapeError

    with pytest.raises(ShapeError, match=r"K must have shape \(1, 4\)"):
        StateFeedbackController(robot, sys, np.zeros((2, 4)))


def test_state_feedback_refuses_another_robots_linearization(robot_loader) -> None:  # type: ignore[no-untyped-def]
    # audit6: StateFeedbackController(ur10, linearize(ur5, ...), K) was accepted (same nq)
    ur5, ur10 = robot_loader("ur5"), robot_loader("ur10")
    sys5 = linearize(ur5, ur5.q_default)
    assert sys5.robot_name == "ur5"
    K = np.zeros((ur5.nv, 2 * ur5.nv))
    StateFeedbackController(ur5, sys5, K)
    with pytest.raises(InvalidInputError, match="linearized on 'ur5', not on 'ur10'"):
        StateFeedbackController(ur10, sys5, K)
