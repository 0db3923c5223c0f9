"""Task- and joint-space interpolation with the sine profile (slides 2:32-2:35)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.features import FramePose, JointConfiguration, Position
from taskspace.ik import joint_space_interpolation, task_space_interpolation
from taskspace.model import Robot
from taskspace.tasks import Task

TCP = "panda_hand_tcp"


def sine(s: np.ndarray) -> np.ndarray:
    """MP_sin(s) = 1/2 (1 - cos(pi s)) (slide 2:33)."""
    return 0.5 * (1.0 - np.cos(np.pi * s))


def test_task_space_interpolation_follows_line_with_sine_profile(panda: Robot) -> None:
    q0 = panda.q_default
    y0 = panda.frame_placement(q0, TCP).translation.copy()
    yT = y0 + np.array([0.1, -0.15, -0.1])
    steps = 60
    task = Task(Position(panda, TCP), gain=0.4)
    posture = Task(JointConfiguration(panda), q0, weight=1e-4)
    result = task_space_interpolation(panda, task, yT, q0, steps, extra_tasks=[posture])
    assert result.success
    assert result.q.shape == (steps + 1, panda.nq)
    np.testing.assert_allclose(result.q[0], q0)
    positions = np.array([panda.frame_placement(q, TCP).translation for q in result.q])
    # reference path: straight line, sine timing
    s = sine(np.arange(steps + 1) / steps)
    reference = y0 + s[:, None] * (yT - y0)
    deviation = np.linalg.norm(positions - reference, axis=1)
    assert deviation.max() < 2e-3  # one-step linearization error along a 0.21 m move
    # distance from the straight line itself (not only from the timed point)
    u = (yT - y0) / np.linalg.norm(yT - y0)
    rel = positions - y0
    off_line = np.linalg.norm(rel - (rel @ u)[:, None] * u, axis=1)
    assert off_line.max() < 1e-3
    np.testing.assert_allclose(positions[-1], yT, atol=1e-3)
    assert task.gain == 0.4  # restored
    np.testing.assert_allclose(result.task_errors, deviation, atol=1e-12)
    # the interpolated targets are the reference points
    np.testing.assert_allclose(np.array(result.task_targets, dtype=float), reference, atol=1e-12)


def test_task_space_interpolation_of_a_pose(panda: Robot) -> None:
    q0 = panda.q_default
    start = panda.frame_placement(q0, TCP)
    goal = pin.SE3(start.rotation @ pin.exp3(np.array([0.0, 0.0, 0.3])), start.translation)
    goal.translation = goal.translation + np.array([0.0, 0.1, 0.05])
    task = Task(FramePose(panda, TCP))
    result = task_space_interpolation(panda, task, goal, q0, 40)
    assert result.success
    final = panda.frame_placement(result.q[-1], TCP)
    assert np.linalg.norm(pin.log6(goal.actInv(final)).vector) < 1e-3


def test_joint_space_interpolation_reaches_target_on_straight_line(panda: Robot) -> None:
    q0 = panda.q_default
    q_goal = q0 + np.array([0.2, -0.1, 0.1, 0.2, -0.1, 0.1, 0.2])
    target = panda.frame_placement(q_goal, TCP)
    task = Task(FramePose(panda, TCP), target)
    steps = 30
    result = joint_space_interpolation(panda, [task], q0, steps)
    assert result.success
    final = panda.frame_placement(result.q[-1], TCP)
    assert np.linalg.norm(final.translation - target.translation) < 1e-6
    assert np.linalg.norm(pin.log3(target.rotation.T @ final.rotation)) < 1e-5
    # q_t = q_0 + MP(t/T)(q_T - q_0)
    s = sine(np.arange(steps + 1) / steps)
    reference = q0 + s[:, None] * (result.q[-1] - q0)
    np.testing.assert_allclose(result.q, reference, atol=1e-12)
    assert result.task_errors[0] > 0.1 and result.task_errors[-1] < 1e-5
