from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import OrientationDMP, quaternion


def _demo() -> tuple[np.ndarray, list[np.ndarray]]:
    t = np.linspace(0, 1, 201)
    mj = 10 * t**3 - 15 * t**4 + 6 * t**5
    Rs = [
        pin.exp3(np.array([0, 0, 1.2 * m])) @ pin.exp3(np.array([0.5 * np.sin(np.pi * s), 0, 0]))
        for m, s in zip(mj, t)
    ]
    return t, Rs


def _angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(Ra.T @ Rb)))


def test_reproduces_the_demonstrated_orientations() -> None:
    t, Rs = _demo()
    dmp = OrientationDMP.fit(t, Rs)
    traj = dmp.rollout(0.001, duration=1.0)
    err = max(_angle(traj.rotations[k], Rs[k // 5]) for k in range(0, traj.time.size, 5))
    assert err < 5e-3
    # The learned forcing term matters: the plain spring is far off.
    plain = OrientationDMP(np.zeros_like(dmp.weights), dmp.R0, dmp.goal, dmp.tau, dmp.options)
    plain.initial_angular_velocity = dmp.initial_angular_velocity
    spring = plain.rollout(0.001, duration=1.0)
    assert max(_angle(spring.rotations[k], Rs[k // 5]) for k in range(0, 1001, 5)) > 0.05


def test_quaternion_input_and_new_goal() -> None:
    t, Rs = _demo()
    dmp = OrientationDMP.fit(t, [quaternion(R) for R in Rs])
    assert _angle(dmp.goal, Rs[-1]) < 1e-12
    goal = pin.exp3(np.array([0.3, -0.4, 0.9]))
    traj = dmp.rollout(0.002, duration=3.0, goal=quaternion(goal))
    assert _angle(traj.rotations[-1], goal) < 1e-3
    assert np.abs(np.linalg.norm(traj.quaternions, axis=1) - 1).max() < 1e-12
    assert np.allclose(traj.rotations[5] @ traj.rotations[5].T, np.eye(3), atol=1e-12)


def test_errors() -> None:
    with pytest.raises(InvalidInputError, match="quaternions"):
        OrientationDMP.fit([0.0, 0.5, 1.0], [np.zeros(3)] * 3)
    with pytest.raises(InvalidInputError, match="increasing"):
        OrientationDMP.fit([0.0, 1.0], [np.eye(3)] * 2)
