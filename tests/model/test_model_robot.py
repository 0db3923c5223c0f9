"""Robot loading, registry, configuration validation and every error path of the model layer."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import (
    InvalidInputError,
    LimitError,
    ModelLoadError,
    NotFiniteError,
    ShapeError,
    UnknownNameError,
)
from taskspace import features as F
from taskspace.model import Obstacle, Robot, registry
from tests.conftest import load_robot

REQUIRED = [
    "panda",
    "ur5",
    "talos",
    "g1",
    "solo12",
    "planar_2link",
    "planar_3link",
    "pendulum",
    "cartpole",
]


def test_registry_covers_required_robots() -> None:
    assert set(REQUIRED) <= set(registry())


@pytest.mark.parametrize("name", REQUIRED)
def test_registry_robot_loads_collision_free_at_default(name: str) -> None:
    robot = load_robot(name)
    assert robot.q_default.shape == (robot.nq,)
    assert robot.is_collision_free(robot.q_default), robot.colliding_pairs(robot.q_default)
    robot.check_limits(robot.q_default)
    for ee in robot.end_effectors:
        robot.frame_id(ee)


def test_dimensions_and_locked_fingers() -> None:
    panda = load_robot("panda")
    assert (panda.nq, panda.nv) == (7, 7)
    assert "panda_finger_joint1" not in panda.joint_names
    talos = load_robot("talos")
    assert (talos.nq, talos.nv, talos.is_floating) == (39, 38, True)
    g1 = load_robot("g1")
    assert (g1.nq, g1.nv) == (36, 35)


def test_srdf_pairs_are_respected() -> None:
    panda = load_robot("panda")
    pairs = set(panda.collision_pairs)
    # adjacent links are disabled in panda.srdf
    assert ("panda_link0_0", "panda_link1_0") not in pairs
    assert len(pairs) == 44


def test_planar_2link_forward_kinematics_closed_form() -> None:
    robot = load_robot("planar_2link")
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(-3, 3, 2)
        p = robot.frame_placement(q, "ee").translation
        expected = [np.cos(q[0]) + np.cos(q[0] + q[1]), np.sin(q[0]) + np.sin(q[0] + q[1]), 0]
        np.testing.assert_allclose(p, expected, atol=1e-12)


@pytest.mark.parametrize("name", ["panda", "talos", "solo12"])
def test_center_of_mass_matches_pinocchio(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(1)
    feature = F.CenterOfMass(robot)
    for _ in range(5):
        q = robot.random_configuration(rng)
        expected = pin.centerOfMass(robot.model, robot.model.createData(), q)
        np.testing.assert_allclose(feature.value(robot.state(q)), expected, atol=1e-12)


def test_state_arrays_are_read_only(panda: Robot) -> None:
    state = panda.state(panda.q_default, np.zeros(7))
    with pytest.raises(ValueError):
        state.q[0] = 1.0
    with pytest.raises(ValueError):
        state.v[0] = 1.0


def test_unknown_robot_lists_valid_names() -> None:
    with pytest.raises(UnknownNameError) as err:
        Robot.load("pandaa")
    msg = str(err.value)
    assert "unknown robot 'pandaa'" in msg and "panda" in msg and "talos" in msg


def test_unknown_frame_lists_valid_frames(panda: Robot) -> None:
    with pytest.raises(UnknownNameError) as err:
        F.Position(panda, "hnd")
    assert "unknown frame 'hnd'; valid frames are:" in str(err.value)
    assert "panda_hand_tcp" in str(err.value)
    assert err.value.valid == sorted(panda.frame_names)


def test_unknown_joint(panda: Robot) -> None:
    with pytest.raises(UnknownNameError, match="unknown joint 'elbow'"):
        panda.joint_id("elbow")


def test_wrong_shape(panda: Robot) -> None:
    with pytest.raises(ShapeError, match=r"q must have shape \(7,\), got \(6,\)"):
        panda.state(np.zeros(6))
    with pytest.raises(ShapeError, match=r"v must have shape \(7,\), got \(3, 3\)"):
        panda.state(panda.q_default, np.zeros((3, 3)))


def test_nan_and_inf(panda: Robot) -> None:
    q = panda.q_default.copy()
    q[2] = np.nan
    with pytest.raises(
        NotFiniteError, match=r"q has non-finite \(NaN or inf\) entries at indices \[2\]"
    ):
        panda.state(q)
    with pytest.raises(NotFiniteError):
        panda.state(panda.q_default, np.full(7, np.inf))


def test_non_numeric(panda: Robot) -> None:
    with pytest.raises(InvalidInputError, match="q must be an array of (real )?numbers"):
        panda.state(["a"] * 7)


def test_non_unit_quaternion(talos: Robot) -> None:
    q = talos.q_default.copy()
    q[3:7] = [0.1, 0.0, 0.0, 1.0]
    with pytest.raises(
        InvalidInputError,
        match=r"q\[3:7\] is the quaternion of joint 'root_joint' and must have unit norm, "
        r"got 1.00498756; call robot.normalize\(q\)",
    ):
        talos.state(q)
    talos.state(talos.normalize(q))


def test_limits(panda: Robot) -> None:
    q = panda.q_default.copy()
    q[3] = 1.0  # panda_joint4 upper limit is about -0.07
    with pytest.raises(LimitError, match="panda_joint4=1 not in") as err:
        panda.check_limits(q)
    assert err.value.indices == [3]


def test_malformed_urdf(tmp_path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(ModelLoadError, match="cannot load URDF"):
        Robot.from_urdf(bad)
    with pytest.raises(ModelLoadError, match="URDF file not found"):
        Robot.from_urdf(tmp_path / "missing.urdf")


def test_feature_on_wrong_robot(panda: Robot) -> None:
    ur5 = load_robot("ur5")
    with pytest.raises(InvalidInputError, match="defined on robot 'panda' but the state belongs"):
        F.Position(panda, "panda_hand_tcp").value(ur5.state())


def test_drift_without_velocity(panda: Robot) -> None:
    with pytest.raises(InvalidInputError, match="needs the velocity"):
        F.Position(panda, "panda_hand_tcp").drift(panda.state())


def test_obstacles_are_checked() -> None:
    robot = Robot.load("panda")
    tcp = robot.frame_placement(robot.q_default, "panda_hand_tcp").translation
    robot.add_obstacle(Obstacle.sphere("ball", 0.05, tcp))
    assert not robot.is_collision_free(robot.q_default)
    assert any("ball" in pair for pair in robot.colliding_pairs(robot.q_default))
    with pytest.raises(InvalidInputError, match="already exists"):
        robot.add_obstacle(Obstacle.sphere("ball", 0.05, tcp))
    robot.clear_obstacles()
    assert robot.is_collision_free(robot.q_default)
    with pytest.raises(InvalidInputError, match="radius must be finite and > 0"):
        Obstacle.sphere("neg", -1.0)


def test_from_urdf_with_free_flyer() -> None:
    from taskspace.model.registry import robot_spec

    spec = robot_spec("planar_2link")
    robot = Robot.from_urdf(spec.urdf, free_flyer=True)  # type: ignore[arg-type]
    assert robot.is_floating and robot.nq == 9 and robot.nv == 8
