"""Trajectory following with IK: joint- and task-space interpolation (slides 2:28, 2:33-2:35).

Thread safety: the functions build their own state and IK solver per call, but
:func:`task_space_interpolation` moves the target of the task it is given (left at the final
target): threads must not share that task. An :class:`InterpolationResult` is plain result data,
not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, check_count
from taskspace.constraints.constraint import Constraint
from taskspace.features.joint_configuration import JointConfiguration
from taskspace.features.orientation import Orientation
from taskspace.ik.differential_ik import DifferentialIK
from taskspace.ik.solve_ik import SolveIKOptions, solve_ik
from taskspace.model.robot import Robot
from taskspace.tasks import Task
from taskspace.trajopt.motion_profile import MotionProfile, SineProfile


@dataclass
class InterpolationResult:
    """A joint trajectory ``q_0:T`` and the task values along it.

    Attributes:
        q: (T+1, nq) configurations.
        task_targets: (T+1, ...) interpolated task targets (task space) or ``None``.
        task_errors: (T+1,) norm of the task error along the trajectory.
        success: the final configuration reaches the target within tolerance.
    """

    q: FloatArray
    task_targets: list[object] | None
    task_errors: FloatArray
    success: bool


def _interpolate_target(task: Task, y0: object, yT: object, s: float) -> object:
    """The target a fraction ``s`` of the way from ``y0`` to ``yT`` on the feature's values.

    Geodesic on SE(3) for poses (frame and relative), on SO(3) for orientations, on the
    configuration manifold (:meth:`Robot.interpolate`) for joint configurations, straight
    for vectors: a straight line between two rotations, or between the (cos, sin) of a
    continuous joint, is not a valid target (it was refused in the middle of the motion).
    """
    feature = task.feature
    if isinstance(y0, pin.SE3):
        return pin.SE3.Interpolate(y0, yT, s)
    if isinstance(feature, Orientation):
        R0 = np.asarray(y0)
        return R0 @ pin.exp3(s * pin.log3(R0.T @ np.asarray(yT)))
    if isinstance(feature, JointConfiguration):
        return feature.robot.interpolate(y0, yT, s)
    return np.asarray(y0) + s * (np.asarray(yT) - np.asarray(y0))


def task_space_interpolation(
    robot: Robot,
    task: Task,
    target: object,
    q0: object,
    steps: int,
    *,
    profile: MotionProfile | None = None,
    extra_tasks: Sequence[Task] = (),
    constraints: Sequence[Constraint] = (),
) -> InterpolationResult:
    """Slide 2:28 / 2:35: interpolate ``y_t = y_0 + MP(t/T)(y_T - y_0)`` and track it with IK.

    ``q_{t+1} = q_t + J# (y_{t+1} - phi(q_t))`` as a differential IK step with gain 1 (plus
    optional extra tasks such as a low-weight posture, and constraints).

    Args:
        robot: the robot.
        task: the task to move (its target is overwritten along the way).
        target: final task value ``y_T``.
        q0: initial configuration.
        steps: number of steps ``T``.
        profile: motion profile (default the sine profile of slide 2:32).
        extra_tasks: other tasks kept during the motion.
        constraints: constraints of each step.
    """
    steps = check_count(steps, "steps", minimum=1)
    profile = profile or SineProfile()
    q = robot.check_configuration(q0, "q0")
    state = robot.state(q)
    y0 = task.feature.value(state)
    yT = task.feature.check_target(target)
    gain = task.gain
    task.gain = 1.0
    ik = DifferentialIK(robot, [task, *extra_tasks], constraints)
    qs = [q]
    targets: list[object] = [y0]
    errors = [0.0]
    try:
        for t in range(1, steps + 1):
            yt = _interpolate_target(task, y0, yT, float(profile.position(t / steps)))
            task.set_target(yt)
            q, _ = ik.step(state, 1.0)
            state.update(q, validate=False)
            qs.append(q)
            targets.append(yt)
            errors.append(float(np.linalg.norm(task.error(state))))
    finally:
        task.gain = gain
        task.set_target(yT)
    final = float(np.linalg.norm(task.error(state)))
    return InterpolationResult(np.array(qs), targets, np.array(errors), final < 1e-3)


def joint_space_interpolation(
    robot: Robot,
    tasks: Sequence[Task],
    q0: object,
    steps: int,
    *,
    profile: MotionProfile | None = None,
    options: SolveIKOptions | None = None,
) -> InterpolationResult:
    """Slide 2:34: solve for ``q_T`` by Gauss-Newton, then ``q_t = q_0 + MP(t/T)(q_T - q_0)``.

    (The metric ``W/T`` of the slide weighs the regularization; :func:`solve_ik` uses an
    adaptive Levenberg-Marquardt damping that vanishes at convergence.)
    """
    steps = check_count(steps, "steps", minimum=1)
    profile = profile or SineProfile()
    q_start = robot.check_configuration(q0, "q0")
    result = solve_ik(robot, tasks, q_start, options=options)
    delta = pin.difference(robot._model, q_start, result.q)
    qs = np.array(
        [
            pin.integrate(robot._model, q_start, float(profile.position(t / steps)) * delta)
            for t in range(steps + 1)
        ]
    )
    state = robot.state(qs[-1])
    errors = np.array([float(np.linalg.norm(tasks[0].error(robot.state(q)))) for q in qs])
    del state
    return InterpolationResult(qs, None, errors, result.success)
