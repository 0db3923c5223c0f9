"""Robot loading, registry, configuration validation and every error path of the model layer."""

from __future__ import annotations

from pathlib import Path

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
    with pytest.raises(InvalidInputError, match=r"q must be (an array of )?real numbers"):
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


# ---------------------------------------------------------------------- package data, names
def test_registry_ships_inside_the_package() -> None:
    from importlib import resources

    from taskspace.model.registry import data_directory

    root = data_directory()
    assert root == resources.files("taskspace") / "robots_data"
    assert (root / "registry.yaml").is_file()
    spec = registry()["planar_2link"]
    assert spec.urdf is not None and spec.urdf.is_file()
    assert str(spec.urdf).startswith(str(root))


def test_every_example_robot_data_name_is_available() -> None:
    from example_robot_data.robots_loader import ROBOTS

    from taskspace.model import available_robots

    names = available_robots()
    assert set(ROBOTS) <= set(names)
    assert set(registry()) <= set(names)
    go2 = names["go2"]
    assert go2.free_flyer and not go2.in_registry and go2.default_posture["srdf"] == "standing"
    with pytest.raises(UnknownNameError) as err:
        Robot.load("go3")
    assert "go2" in str(err.value) and "planar_2link" in str(err.value)


def test_erd_robot_outside_the_registry_loads_with_its_srdf_posture() -> None:
    import example_robot_data

    robot = Robot.load("go2")
    reference = example_robot_data.load("go2")
    assert (robot.nq, robot.nv, robot.is_floating) == (reference.model.nq, reference.model.nv, True)
    np.testing.assert_allclose(robot.q_default, reference.q0, atol=1e-12)
    assert robot.srdf_path is not None and robot.srdf_path.endswith("go2.srdf")
    assert robot.is_collision_free(robot.q_default)


def test_robot_listing_is_cached(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import importlib

    reg = importlib.import_module("taskspace.model.registry")  # the module, not the function
    monkeypatch.setenv(reg.CACHE_ENVIRONMENT_VARIABLE, str(tmp_path))
    everything = reg.available_robots()
    some = {n: everything[n] for n in ("panda", "go2", "kinova", "cassie", "planar_2link")}
    monkeypatch.setattr(reg, "available_robots", lambda: some)  # a fast cold listing
    first = reg.robot_summaries()
    assert set(first) == set(some)
    files = list(tmp_path.glob("robots-*.json"))
    assert len(files) == 1
    assert first["panda"]["nq"] == 7 and first["go2"]["nq"] == 19 and first["kinova"]["nv"] == 6
    assert first["planar_2link"]["source"] == "registry" and first["go2"]["floating"]
    assert first["cassie"]["nq"] is None and "SDF" in first["cassie"]["error"]

    def fail(spec):  # type: ignore[no-untyped-def]
        raise AssertionError("a warm listing must not read the models")

    monkeypatch.setattr(reg, "_kinematic_size", fail)
    assert reg.robot_summaries() == first


def test_malformed_registry_gives_the_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from taskspace.model.registry import _registry_entries

    path = tmp_path / "registry.yaml"
    with pytest.raises(ModelLoadError, match=r"registry.yaml: entry 'x': unknown source 'git'"):
        _registry_entries({"x": {"source": "git"}}, path)
    with pytest.raises(ModelLoadError, match="must be a mapping"):
        _registry_entries(["x"], path)


# ---------------------------------------------------------------------- checks on load
TINY_URDF = """<robot name="tiny">
  <link name="base">
    <collision><origin xyz="2 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <link name="l1">
    <inertial><mass value="1"/>{INERTIA}</inertial>
    <collision><geometry><sphere radius="0.5"/></geometry></collision>
  </link>
  <link name="l2">
    <inertial><mass value="1"/>{INERTIA}</inertial>
  </link>
  <link name="l3">
    <inertial><mass value="1"/>{INERTIA}</inertial>
    <collision><geometry><sphere radius="0.2"/></geometry></collision>
  </link>
  <link name="l4">
    <inertial><mass value="1"/>{INERTIA}</inertial>
    <collision><origin xyz="1.6 0 0"/><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="5" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="0" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="5" velocity="0"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="5" velocity="1"/></joint>
</robot>
"""
TINY_URDF = TINY_URDF.replace(
    "{INERTIA}", '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
)
SRDF_L3_L4 = """<robot name="tiny">
  <disable_collisions link1="l3" link2="l4" reason="Adjacent"/>
</robot>
"""


@pytest.fixture
def tiny_urdf(tmp_path):  # type: ignore[no-untyped-def]
    path = tmp_path / "tiny.urdf"
    path.write_text(TINY_URDF)
    return path


def _collision_frequency(robot: Robot, pair: tuple[str, str], n: int = 400) -> float:
    """Fraction of random configurations where ``pair`` collides, with Pinocchio directly."""
    cm = pin.GeometryModel()
    for g in robot.collision_model.geometryObjects:
        cm.addGeometryObject(g)
    cm.addCollisionPair(pin.CollisionPair(cm.getGeometryId(pair[0]), cm.getGeometryId(pair[1])))
    cd = cm.createData()
    data = robot.model.createData()
    rng = np.random.default_rng(99)
    hits = 0
    for _ in range(n):
        q = robot.random_configuration(rng)
        hits += bool(pin.computeCollisions(robot.model, data, cm, cd, q, True))
    return hits / n


def test_pruning_rules_without_srdf(tiny_urdf) -> None:  # type: ignore[no-untyped-def]
    from taskspace.errors import ModelWarning

    with pytest.warns(ModelWarning, match="in collision at the default posture") as record:
        robot = Robot.from_urdf(tiny_urdf, passive_joints=["j2"])
    pruned = robot.pruned_collision_pairs
    assert set(pruned.adjacent) == {("base_0", "l1_0"), ("l3_0", "l4_0")}
    assert set(pruned.default_posture) == {("base_0", "l4_0"), ("l1_0", "l3_0")}
    assert robot.collision_pairs == [("base_0", "l3_0"), ("l1_0", "l4_0")]
    assert robot.is_collision_free(robot.q_default)
    messages = " ".join(str(w.message) for w in record)
    assert "j3" in messages and "no velocity limit" in messages
    assert "no effort limit" not in messages  # j2 is declared passive


def test_always_rule_matches_an_independent_count(tiny_urdf) -> None:  # type: ignore[no-untyped-def]
    from taskspace.errors import ModelWarning
    from taskspace.model import CollisionPruningOptions

    options = CollisionPruningOptions(default_posture=False)
    with pytest.warns(ModelWarning, match=r">= 95% of 100 random configurations"):
        robot = Robot.from_urdf(tiny_urdf, collision_pruning=options, passive_joints=["j2"])
    assert robot.pruned_collision_pairs.always == (("l1_0", "l3_0"),)
    assert ("base_0", "l4_0") in robot.collision_pairs  # collides at q = 0 only
    assert _collision_frequency(robot, ("l1_0", "l3_0")) == 1.0
    for pair in robot.collision_pairs:
        assert _collision_frequency(robot, pair) < 0.95, pair
    kept = Robot.from_urdf(
        tiny_urdf, collision_pruning=CollisionPruningOptions(enabled=False), passive_joints=["j2"]
    )
    assert ("l1_0", "l3_0") in kept.collision_pairs and ("l3_0", "l4_0") in kept.collision_pairs


def test_pruning_also_applies_with_an_srdf(tiny_urdf, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from taskspace.errors import ModelWarning

    srdf = tmp_path / "tiny.srdf"
    srdf.write_text(SRDF_L3_L4)
    with pytest.warns(ModelWarning, match="left by its SRDF were disabled"):
        robot = Robot.from_urdf(tiny_urdf, srdf=srdf, passive_joints=["j2"])
    assert robot.pruned_collision_pairs.adjacent == ()  # the SRDF decides adjacency
    assert ("l3_0", "l4_0") not in robot.collision_pairs
    assert ("l1_0", "l3_0") not in robot.collision_pairs


def _reference_self_collision_rate(robot: Robot, samples: int, seed: int) -> float:
    """The same random configurations as the load-time estimate, counted by Pinocchio."""
    model, geometry = robot.model, robot.collision_model  # the pruned pairs, no obstacles
    data, gdata = model.createData(), geometry.createData()
    rng = np.random.default_rng(seed + 1)
    hits = 0
    for _ in range(samples):
        q = robot.random_configuration(rng)
        hits += bool(pin.computeCollisions(model, data, geometry, gdata, q, True))
    return hits / samples


@pytest.mark.parametrize(("name", "warned"), [("icub_reduced", True), ("talos", False)])
def test_self_collision_rate_after_pruning_is_measured_and_warned(name: str, warned: bool) -> None:
    """icub's pairs each collide in < 95 % of random configurations, the robot in all of them."""
    import warnings

    from taskspace.errors import ModelWarning
    from taskspace.model import CollisionPruningOptions

    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        robot = Robot.load(name)
    said = [str(w.message) for w in record if issubclass(w.category, ModelWarning)]
    flagged = [m for m in said if "in self-collision after pruning" in m]
    pruned = robot.pruned_collision_pairs
    options = CollisionPruningOptions()
    assert pruned.rate_samples == 20
    reference = _reference_self_collision_rate(robot, pruned.rate_samples, options.seed)
    assert pruned.self_collision_rate == reference
    assert bool(flagged) == warned
    if warned:
        assert reference >= options.fraction and "most often in contact" in flagged[0]
    else:
        assert 0.0 < reference < options.fraction


def test_missing_effort_is_unlimited_with_a_warning(tiny_urdf) -> None:  # type: ignore[no-untyped-def]
    from taskspace.errors import ModelWarning

    with pytest.warns(ModelWarning, match=r"\['j2'\] have no effort limit"):
        robot = Robot.from_urdf(tiny_urdf)
    np.testing.assert_array_equal(robot.effort_limits, [5.0, np.inf, 5.0, 5.0])
    np.testing.assert_array_equal(robot.velocity_limits, [1.0, 1.0, np.inf, 1.0])
    assert robot.passive_joints == ()
    with pytest.warns(ModelWarning):
        passive = Robot.from_urdf(tiny_urdf, passive_joints=["j2"])
    np.testing.assert_array_equal(passive.effort_limits, [5.0, 0.0, 5.0, 5.0])
    assert passive.passive_joints == ("j2",)
    with pytest.raises(UnknownNameError, match="unknown joint 'j9'"):
        Robot.from_urdf(tiny_urdf, passive_joints=["j9"])


def test_cartpole_hinge_is_declared_passive() -> None:
    cartpole = load_robot("cartpole")
    assert cartpole.passive_joints == ("hinge",)
    np.testing.assert_array_equal(cartpole.effort_limits, [50.0, 0.0])


def test_erd_robot_without_effort_limits_is_actuated() -> None:
    """double_pendulum has effort="0" everywhere: unlimited and actuated, never silently passive."""
    from taskspace.errors import ModelWarning

    with pytest.warns(ModelWarning, match="no effort limit"):
        robot = Robot.load("double_pendulum")
    assert np.all(robot.effort_limits == np.inf)
    assert np.all(robot.velocity_limits == np.inf)


def test_velocity_limits_of_a_floating_base_are_accepted() -> None:
    from taskspace.constraints import JointVelocityLimits

    solo = load_robot("solo12")
    limits = solo.velocity_limits
    assert np.all(np.isinf(limits[:6])) and np.all(np.isfinite(limits[6:]))
    constraint = JointVelocityLimits(solo, limits=limits)
    lb, ub = constraint.bounds(solo.state(), 0.01)
    np.testing.assert_allclose(ub[6:], limits[6:] * 0.01)
    assert np.all(ub[:6] >= 1e19) and np.all(lb[:6] <= -1e19)
    for bad, message in [
        (np.zeros(solo.nv), "must be > 0"),
        (np.full(solo.nv, np.nan), "must be > 0"),
        (np.full(solo.nv, -np.inf), "must be > 0"),
        (np.ones(3), r"limits must have shape \(18,\)"),
        (["a"] * solo.nv, "real numbers"),
    ]:
        with pytest.raises(InvalidInputError, match=message):
            JointVelocityLimits(solo, limits=bad)


def test_default_posture_is_moved_into_the_limits(tiny_urdf) -> None:  # type: ignore[no-untyped-def]
    from taskspace.errors import ModelWarning

    q = [0.0, 2 * np.pi + 0.05, 0.5, 0.0]  # j2: same pose as 0.05; j3: beyond its 0.1 limit
    with pytest.warns(ModelWarning, match=r"outside the joint limits; clipped: j3=0\.5 -> 0\.1"):
        robot = Robot.from_urdf(tiny_urdf, default_configuration=q, passive_joints=["j2"])
    np.testing.assert_allclose(robot.q_default, [0.0, 0.05, 0.1, 0.0], atol=1e-12)
    robot.check_limits(robot.q_default)


def test_kinova_reference_posture_is_wrapped_not_clipped() -> None:
    """kinova.srdf's arm_up has joint 3 at -pi/2, outside [0.33, 5.95]: the same pose + 2 pi."""
    import example_robot_data

    kinova = load_robot("kinova")
    reference = example_robot_data.load("kinova")
    kinova.check_limits(kinova.q_default)
    for frame in ("j2s6s200_end_effector", "j2s6s200_link_6"):
        fid = reference.model.getFrameId(frame)
        pin.framesForwardKinematics(reference.model, reference.data, reference.q0)
        expected = reference.data.oMf[fid]
        actual = kinova.frame_placement(kinova.q_default, frame)
        np.testing.assert_allclose(actual.homogeneous, expected.homogeneous, atol=1e-12)


def test_geometries_of_missing_joints_are_dropped() -> None:
    """example-robot-data's talos_legs keeps the whole robot's collision geometry on a legs-only
    model; Pinocchio would read past the end of Data for those geometries."""
    import coal

    from taskspace.errors import ModelWarning
    from taskspace.model.robot import _drop_orphan_geometries

    model = pin.Model()
    model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    geometry = pin.GeometryModel()
    for name, joint in (("ok", 1), ("orphan", 7)):
        geometry.addGeometryObject(
            pin.GeometryObject(name, joint, 0, pin.SE3.Identity(), coal.Sphere(0.1))
        )
    with pytest.warns(ModelWarning, match=r"1 collision geometries .* removed: \['orphan'\]"):
        _drop_orphan_geometries(model, geometry, "test", "collision")
    assert [g.name for g in geometry.geometryObjects] == ["ok"]


def test_from_urdf_missing_mesh_names_the_search_directories(tmp_path: Path) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        """<robot name="arm">
  <link name="base"><collision><geometry>
    <mesh filename="package://nowhere/meshes/base.stl"/></geometry></collision></link>
  <link name="l1"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""
    )
    with pytest.raises(ModelLoadError, match=r"mesh file could not be found.*package_dirs"):
        Robot.from_urdf(urdf, package_dirs=[str(tmp_path)])
    assert Robot.from_urdf(urdf, geometry=False).nq == 1  # the kinematics alone load
