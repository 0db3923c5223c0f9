"""Every feature's Jacobian and drift against central finite differences.

Jacobian column k: ``(f(q (+) eps e_k) - f(q (-) eps e_k)) / 2 eps`` with ``(+)`` Pinocchio's
``integrate`` (tangent space, as the analytic Jacobians). Drift: the finite difference of
``J(q) v`` along ``q(t) = q (+) t v``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.model import Robot, State
from tests.conftest import load_robot
from tests.problems import random_configurations, random_velocity

EPS = 1e-6
RTOL = 1e-6  # relative to the Jacobian's largest entry
ATOL = 1e-7
N_CONFIGS = 20

ROBOTS = ["panda", "ur5", "talos", "solo12", "planar_2link", "planar_3link", "g1"]


def _frames(robot: Robot) -> tuple[str, str]:
    ee = robot.end_effectors
    return ee[0], ee[1] if len(ee) > 1 else robot.frame_names[3]


def feature_builders() -> dict[str, Callable[[Robot], F.Feature]]:
    def pos(r: Robot) -> F.Feature:
        return F.Position(r, _frames(r)[0], offset=[0.03, -0.02, 0.05])

    def vec(r: Robot) -> F.Feature:
        return F.Vector(r, _frames(r)[0], [0.3, 0.5, -0.8])

    def relpos(r: Robot) -> F.Feature:
        a, b = _frames(r)
        return F.RelativePosition(r, a, b, [0.01, 0.02, 0.03], [0.05, -0.01, 0.02])

    def relvec(r: Robot) -> F.Feature:
        a, b = _frames(r)
        return F.RelativeVector(r, a, b, [0.0, 0.6, 0.8])

    def align(r: Robot) -> F.Feature:
        return F.Alignment(r, _frames(r)[0], [0, 0, 1], [0.6, 0.0, 0.8])

    def relalign(r: Robot) -> F.Feature:
        a, b = _frames(r)
        return F.RelativeAlignment(r, a, [1, 0, 0], b, [0, 0.6, 0.8])

    def com(r: Robot) -> F.Feature:
        return F.CenterOfMass(r)

    def pose(r: Robot) -> F.Feature:
        return F.FramePose(r, _frames(r)[0])

    def orient(r: Robot) -> F.Feature:
        return F.Orientation(r, _frames(r)[0])

    def posture(r: Robot) -> F.Feature:
        return F.JointConfiguration(r)

    def limits(r: Robot) -> F.Feature:
        return F.JointLimitPenetration(r, margin=0.3)

    return {
        "position": pos,
        "vector": vec,
        "relative_position": relpos,
        "relative_vector": relvec,
        "alignment": align,
        "relative_alignment": relalign,
        "center_of_mass": com,
        "frame_pose": pose,
        "orientation": orient,
        "joint_configuration": posture,
        "joint_limit_penetration": limits,
    }


def _as_array(value: object) -> np.ndarray:
    if isinstance(value, pin.SE3):
        return np.asarray(value.homogeneous).ravel()
    return np.asarray(value, dtype=float).ravel()


def _tangent_of_value(feature: F.Feature, ref_state: State) -> Callable[[State], np.ndarray]:
    """Map a state to coordinates whose derivative is ``feature.jacobian``."""
    if isinstance(feature, F.FramePose):
        T0 = feature.value(ref_state)
        return lambda s: np.asarray(pin.log6(T0.actInv(feature.value(s))).vector)
    if isinstance(feature, F.Orientation):
        R0 = feature.value(ref_state)
        return lambda s: np.asarray(pin.log3(R0.T @ feature.value(s)))
    if isinstance(feature, F.JointConfiguration):
        q0 = ref_state.q.copy()
        rows = slice(None) if feature.rows is None else feature.rows  # the selected rows
        return lambda s: np.asarray(pin.difference(feature.robot.model, q0, s.q))[rows]
    return lambda s: _as_array(feature.value(s))


def fd_jacobian(robot: Robot, f: Callable[[State], np.ndarray], q: np.ndarray) -> np.ndarray:
    cols = []
    plus, minus = robot.state(q), robot.state(q)
    for k in range(robot.nv):
        dq = np.zeros(robot.nv)
        dq[k] = EPS
        plus.update(pin.integrate(robot.model, q, dq))
        minus.update(pin.integrate(robot.model, q, -dq))
        cols.append((f(plus) - f(minus)) / (2 * EPS))
    return np.array(cols).T


def assert_close(actual: np.ndarray, expected: np.ndarray, what: str) -> None:
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    err = float(np.abs(actual - expected).max(initial=0.0))
    assert err <= RTOL * scale + ATOL, f"{what}: max error {err:.3e} (scale {scale:.3g})"


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("feature_name", list(feature_builders()))
def test_jacobian_matches_finite_differences(robot_name: str, feature_name: str) -> None:
    robot = load_robot(robot_name)
    feature = feature_builders()[feature_name](robot)
    for i, q in enumerate(random_configurations(robot, N_CONFIGS, seed=7)):
        if feature_name == "joint_limit_penetration":
            # stay away from the kinks of [.]_+ where the derivative jumps
            q = _away_from_kinks(robot, q, feature)  # type: ignore[arg-type]
        state = robot.state(q)
        f = _tangent_of_value(feature, state)
        J = feature.jacobian(state)
        assert J.shape == (feature.dim, robot.nv)
        assert_close(J, fd_jacobian(robot, f, q), f"{feature_name} on {robot_name}, config {i}")


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("feature_name", list(feature_builders()))
def test_drift_matches_finite_differences(robot_name: str, feature_name: str) -> None:
    robot = load_robot(robot_name)
    feature = feature_builders()[feature_name](robot)
    for i, q in enumerate(random_configurations(robot, N_CONFIGS // 4, seed=11)):
        v = random_velocity(robot, seed=i)
        state = robot.state(q, v)
        drift = feature.drift(state)
        plus = robot.state(pin.integrate(robot.model, q, EPS * v))
        minus = robot.state(pin.integrate(robot.model, q, -EPS * v))
        expected = (feature.jacobian(plus) @ v - feature.jacobian(minus) @ v) / (2 * EPS)
        assert_close(drift, expected, f"drift of {feature_name} on {robot_name}, config {i}")


@pytest.mark.parametrize("robot_name", ["panda", "talos", "ur5"])
def test_frame_pose_residual_jacobian(robot_name: str) -> None:
    robot = load_robot(robot_name)
    frame = robot.end_effectors[0]
    for feature in (F.FramePose(robot, frame), F.Orientation(robot, frame)):
        q_target, *qs = random_configurations(robot, 6, seed=3)
        target_state = robot.state(q_target)
        target = feature.value(target_state)
        for q in qs:
            state = robot.state(q)
            expected = fd_jacobian(robot, lambda s, f=feature, t=target: f.residual(s, t), q)
            assert_close(feature.residual_jacobian(state, target), expected, feature.name)


def test_joint_configuration_residual_jacobian_on_floating_base() -> None:
    robot = load_robot("talos")
    feature = F.JointConfiguration(robot)
    q_target, q = random_configurations(robot, 2, seed=5)
    state = robot.state(q)
    expected = fd_jacobian(robot, lambda s: feature.residual(s, q_target), q)
    assert_close(feature.residual_jacobian(state, q_target), expected, "posture residual")


def _away_from_kinks(robot: Robot, q: np.ndarray, feature: F.JointLimitPenetration) -> np.ndarray:
    q = q.copy()
    idx = robot.limited_joints_q
    lo, hi = robot.lower_limits[idx], robot.upper_limits[idx]
    m = feature.margin
    for kink in (lo + m, hi - m):
        close = np.abs(q[idx] - kink) < 1e-3
        q[idx[close]] += 2e-3
    return q


@pytest.mark.parametrize("robot_name", ["panda", "planar_3link"])
def test_collision_distance_jacobian(robot_name: str) -> None:
    from taskspace.model import Obstacle

    robot = Robot.load(robot_name, convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("ball", 0.1, [0.4, 0.3, 0.5]))
    robot.add_obstacle(Obstacle.box("block", [0.2, 0.3, 0.4], [0.5, -0.4, 0.3]))
    feature = F.CollisionDistance(robot)
    eps = 1e-5
    checked = 0
    for q in random_configurations(robot, 10, seed=21):
        state = robot.state(q)
        d = feature.value(state)
        if np.any(d < 0.005):  # FD across contact changes of witness features is not smooth
            continue
        J = feature.jacobian(state)
        cols, smooth = [], []
        for k in range(robot.nv):
            dq = np.zeros(robot.nv)
            dq[k] = eps
            dp = feature.value(robot.state(pin.integrate(robot.model, q, dq)))
            dm = feature.value(robot.state(pin.integrate(robot.model, q, -dq)))
            cols.append((dp - dm) / (2 * eps))
            # distances of polytopes have kinks (nearest feature switches): compare only
            # where the one-sided differences agree, i.e. where the distance is differentiable
            smooth.append(np.abs((dp - d) - (d - dm)) / eps < 1e-4)
        fd = np.array(cols).T
        mask = np.array(smooth).T
        assert mask.mean() > 0.5
        err = np.abs(J - fd)[mask].max()
        assert err < 2e-3, f"collision distance Jacobian error {err:.2e}"
        checked += 1
    assert checked >= 3
