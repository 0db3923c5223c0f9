"""AngularMomentum: Jacobian and drift against Pinocchio's centroidal momentum and finite
differences; as an inverse-dynamics task it regulates L (issue #16, item 5)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import TaskspaceError
from taskspace.tasks import Task
from tests.conftest import load_robot
from tests.problems import random_configurations, random_velocity


@pytest.mark.parametrize("name", ["g1", "panda", "solo12"])
def test_jacobian_and_drift_match_pinocchio_and_finite_differences(name: str) -> None:
    robot = load_robot(name)
    feature = F.AngularMomentum(robot)
    model = robot.model
    data = model.createData()
    for seed, q in enumerate(random_configurations(robot, 3, seed=2)):
        v = random_velocity(robot, seed)
        state = robot.state(q, v)
        J = feature.jacobian(state)
        pin.computeCentroidalMomentum(model, data, q, v)
        np.testing.assert_allclose(J @ v, data.hg.angular, atol=1e-10)
        np.testing.assert_allclose(feature.momentum(state), data.hg.angular, atol=1e-10)
        a = np.random.default_rng(seed).normal(size=robot.nv)
        pin.computeCentroidalMomentumTimeVariation(model, data, q, v, a)
        np.testing.assert_allclose(J @ a + feature.drift(state), data.dhg.angular, atol=1e-8)
        h = 1e-6
        Jp = feature.jacobian(robot.state(pin.integrate(model, q, h * v)))
        Jm = feature.jacobian(robot.state(pin.integrate(model, q, -h * v)))
        expected = (Jp - Jm) @ v / (2 * h)
        np.testing.assert_allclose(
            feature.drift(state), expected, atol=1e-6 * max(1.0, np.abs(expected).max())
        )


def test_inverse_dynamics_regulates_the_angular_momentum() -> None:
    robot = load_robot("g1")
    rng = np.random.default_rng(4)
    q = robot.q_default.copy()
    q[7:] += rng.normal(scale=0.03, size=robot.nq - 7)
    v = 0.3 * rng.normal(size=robot.nv)
    s = robot.state(q, v)
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03)
        for f in ("left_ankle_roll_link", "right_ankle_roll_link")
    ]
    kd = 5.0
    momentum = Task(F.AngularMomentum(robot), kp=0.0, kd=kd, priority=0)
    L_ref = np.array([0.1, -0.2, 0.05])
    momentum.set_reference(velocity=L_ref)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=1)
    ctrl = InverseDynamicsQP(
        robot, [momentum, posture], contacts, InverseDynamicsOptions(hierarchical=True)
    )
    res = ctrl.solve(s)
    assert res.success, res.status
    data = robot.model.createData()
    pin.computeCentroidalMomentumTimeVariation(robot.model, data, q, v, res.a)
    L = np.asarray(data.hg.angular)
    # the top-priority task holds exactly: L_dot = -kd (L - L_ref)
    np.testing.assert_allclose(data.dhg.angular, -kd * (L - L_ref), atol=1e-6)
    assert np.abs(L - L_ref).max() > 0.1  # the test is not trivial


def test_errors() -> None:
    robot = load_robot("g1")
    feature = F.AngularMomentum(robot)
    with pytest.raises(TaskspaceError, match="set_reference"):
        Task(feature, [1.0, 0.0, 0.0])
    with pytest.raises(TaskspaceError, match="velocity"):
        feature.drift(robot.state(robot.q_default))
