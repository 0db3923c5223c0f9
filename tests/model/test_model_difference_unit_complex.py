"""Robot.difference / distance on continuous joints whose unit complex is off unit norm.

Pinocchio's SO(2) logarithm returns 0 for angles 1e-4 rad apart when the (cos, sin) pair has
norm 1 + 1e-7 (accepted: within QUATERNION_TOLERANCE), so Robot.distance said two different
configurations were the same. Reference: the angles the pairs were built from, and
``pin.difference`` on exactly unit inputs.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Robot


@pytest.fixture(scope="module")
def tiago() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its adjacency-rule collision pairs warning
        return Robot.load("tiago")


def _continuous(robot: Robot) -> list[tuple[int, int]]:
    return [(j.idx_q, j.idx_v) for j in robot.model.joints[1:] if j.nq == 2 and j.nv == 1]


@pytest.mark.parametrize("scale", [1 + 1e-7, 1 - 1e-7, 1 + 9e-7])
@pytest.mark.parametrize("gap", [1e-4, 1e-3, -2e-4])
def test_nearby_angles_off_unit_norm(tiago: Robot, scale: float, gap: float) -> None:
    joints = _continuous(tiago)
    assert joints, "tiago has continuous wheel joints"
    q0 = tiago.q_default.copy()
    q1 = q0.copy()
    for k, (iq, _) in enumerate(joints):
        a = 0.3 + k
        q0[iq : iq + 2] = scale * np.cos(a), scale * np.sin(a)
        q1[iq : iq + 2] = scale * np.cos(a + gap), scale * np.sin(a + gap)
    d = tiago.difference(q0, q1)
    for _, iv in joints:
        assert d[iv] == pytest.approx(gap, rel=1e-9)
    assert tiago.distance(q0, q1) == pytest.approx(abs(gap) * np.sqrt(len(joints)), rel=1e-9)
    # and the robot's interpolation ends where the difference says
    np.testing.assert_allclose(
        tiago.integrate(pin.normalize(tiago.model, q0), d),
        pin.normalize(tiago.model, q1),
        atol=1e-12,
    )


def test_equals_pinocchio_on_unit_inputs(tiago: Robot) -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        q0 = pin.randomConfiguration(tiago.model, -np.ones(tiago.nq), np.ones(tiago.nq))
        q1 = pin.randomConfiguration(tiago.model, -np.ones(tiago.nq), np.ones(tiago.nq))
        q0 = np.clip(q0, tiago.model.lowerPositionLimit, tiago.model.upperPositionLimit)
        q1 = np.clip(q1, tiago.model.lowerPositionLimit, tiago.model.upperPositionLimit)
        q0, q1 = pin.normalize(tiago.model, q0), pin.normalize(tiago.model, q1)
        for iq, _ in _continuous(tiago):  # random angles, exactly unit
            a, b = rng.uniform(-np.pi, np.pi, 2)
            q0[iq : iq + 2] = np.cos(a), np.sin(a)
            q1[iq : iq + 2] = np.cos(b), np.sin(b)
        np.testing.assert_allclose(
            tiago.difference(q0, q1), pin.difference(tiago.model, q0, q1), atol=1e-12
        )


def test_vector_joint_robot_is_pinocchio_exactly() -> None:
    panda = Robot.load("panda")
    rng = np.random.default_rng(0)
    for _ in range(10):
        q0, q1 = rng.uniform(-2, 2, (2, panda.nq))
        assert np.array_equal(panda.difference(q0, q1), pin.difference(panda.model, q0, q1))
