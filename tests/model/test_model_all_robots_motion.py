"""Every robot of example-robot-data: drifts match finite differences, IK reaches targets.

For each robot (kinematics only, ``geometry=False``) and its deepest frame (the one with the
most joints between it and the root):

* the drifts ``Jdot v`` of the frame's pose, of its position and of the centre of mass match
  central finite differences of ``J(q) v`` along ``v`` (on the manifold, ``pin.integrate``);
* a target pose is made reachable by construction (the frame's placement at a random
  configuration 5 % inside the joint limits, computed by Pinocchio); ``DifferentialIK``
  (pose task, position and velocity limits) driven from the default posture reaches it
  within 400 steps without ever leaving the limits, and ``solve_ik`` reaches it as well. Both
  results are checked with Pinocchio's forward kinematics, not with the solvers' own errors;
* toward a target whose configuration has every limited joint 0.3 past a limit, 100 steps of
  ``DifferentialIK`` and ``solve_ik`` stay within the limits (Pinocchio's arrays).

Robots that cannot be loaded are those of ``EXPECTED_FAILURES`` in test_model_all_robots.py.
The whole file takes about 30 s.
"""

from __future__ import annotations

import warnings
import zlib

import numpy as np
import pinocchio as pin
import pytest
from example_robot_data.robots_loader import ROBOTS

from taskspace import features as F
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.ik import DifferentialIK, SolveIKOptions, solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task

pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore")]

UNLOADABLE = {"cassie"}  # SDF; see EXPECTED_FAILURES in test_model_all_robots.py
NAMES = sorted(set(ROBOTS) - UNLOADABLE)
EPS = 1e-6
STEPS = 400
DT = 0.02
TOLERANCE = 1e-6  # |log6| of the pose error reached


def _load(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load(name, geometry=False)


def _deepest_frame(robot: Robot) -> str:
    model = robot.model
    return max(
        robot.frame_names,
        key=lambda n: (len(model.supports[model.frames[robot.frame_id(n)].parentJoint]), n),
    )


def _pose_error(robot: Robot, q: np.ndarray, frame: str, target: pin.SE3) -> float:
    """|log6(M(q)^-1 target)| with Pinocchio's forward kinematics, independent of taskspace."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return float(np.linalg.norm(pin.log6(data.oMf[robot.frame_id(frame)].actInv(target)).vector))


def _within_limits(robot: Robot, q: np.ndarray) -> bool:
    idx = robot.limited_joints_q
    lower = robot.model.lowerPositionLimit[idx]  # Pinocchio's own arrays
    upper = robot.model.upperPositionLimit[idx]
    return bool(np.all(q[idx] >= lower - 1e-9) and np.all(q[idx] <= upper + 1e-9))


@pytest.mark.parametrize("name", NAMES)
def test_drifts_match_finite_differences(name: str) -> None:
    robot = _load(name)
    rng = np.random.default_rng(zlib.crc32(name.encode()) + 1)
    q = robot.random_configuration(rng)
    v = rng.uniform(-1.0, 1.0, robot.nv)
    frame = _deepest_frame(robot)
    plus = robot.state(pin.integrate(robot.model, q, EPS * v))
    minus = robot.state(pin.integrate(robot.model, q, -EPS * v))
    state = robot.state(q, v)
    for feature in (F.FramePose(robot, frame), F.Position(robot, frame), F.CenterOfMass(robot)):
        expected = (feature.jacobian(plus) @ v - feature.jacobian(minus) @ v) / (2 * EPS)
        drift = feature.drift(state)
        scale = max(1.0, float(np.abs(expected).max()))
        np.testing.assert_allclose(
            drift, expected, atol=1e-5 * scale, rtol=0, err_msg=f"{type(feature).__name__}"
        )


@pytest.mark.parametrize("name", NAMES)
def test_ik_reaches_reachable_targets_within_limits(name: str) -> None:
    robot = _load(name)
    frame = _deepest_frame(robot)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    q_start = robot.q_default
    q_goal = pin.integrate(robot.model, q_start, 0.3 * rng.standard_normal(robot.nv))
    idx = robot.limited_joints_q
    lo, hi = robot.lower_limits[idx], robot.upper_limits[idx]
    q_goal[idx] = np.clip(q_goal[idx], lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo))
    target = robot.frame_placement(q_goal, frame)
    assert _pose_error(robot, q_start, frame, target) > 1e-2  # the target is a real motion

    ik = DifferentialIK(
        robot,
        [Task(F.FramePose(robot, frame), target)],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )
    state = robot.state(q_start)
    for step in range(STEPS):
        result = ik.advance(state, DT)
        assert result.success, f"step {step}: {result.status}"
        assert _within_limits(robot, state.q), f"step {step}: q left the joint limits"
        if _pose_error(robot, state.q, frame, target) < TOLERANCE:
            break
    assert _pose_error(robot, state.q, frame, target) < TOLERANCE, f"not reached in {STEPS}"

    solved = solve_ik(
        robot,
        [Task(F.FramePose(robot, frame), target)],
        options=SolveIKOptions(restarts=3),
        rng=np.random.default_rng(1),
    )
    assert solved.success, solved.status
    assert _pose_error(robot, solved.q, frame, target) < 1e-5
    assert _within_limits(robot, solved.q)


@pytest.mark.parametrize("name", NAMES)
def test_ik_toward_a_target_beyond_the_limits_stays_within_them(name: str) -> None:
    """The target's configuration has every limited joint 0.3 rad (or m) past a limit."""
    robot = _load(name)
    idx = robot.limited_joints_q
    if idx.size == 0:
        pytest.skip("no limited joint")
    frame = _deepest_frame(robot)
    rng = np.random.default_rng(zlib.crc32(name.encode()) + 2)
    q_out = robot.q_default.copy()
    side = rng.integers(0, 2, idx.size).astype(bool)
    q_out[idx] = np.where(side, robot.upper_limits[idx] + 0.3, robot.lower_limits[idx] - 0.3)
    target = robot.frame_placement(robot.normalize(q_out), frame)
    ik = DifferentialIK(
        robot,
        [Task(F.FramePose(robot, frame), target)],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )
    state = robot.state(robot.q_default)
    for step in range(100):
        ik.advance(state, DT)
        assert _within_limits(robot, state.q), f"step {step}: q left the joint limits"
    solved = solve_ik(robot, [Task(F.FramePose(robot, frame), target)])
    assert _within_limits(robot, solved.q)
