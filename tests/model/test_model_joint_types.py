"""Every joint type of Pinocchio in the model layer, against Pinocchio's own Lie-group functions.

Robots are built in code with one joint of each type (bounded and unbounded revolute and
prismatic on any axis, continuous ``RUBX/Y/Z`` and unaligned, spherical, spherical ZYX,
planar, translation, free-flyer), plus kinova and tiago (continuous joints) of
example-robot-data.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from taskspace import InvalidInputError, LimitError, ModelLoadError
from taskspace.model import Robot
from tests.conftest import load_robot

AXIS = np.array([0.6, 0.0, 0.8])

# (name, joint model, bounded limits or None)
JOINTS = [
    ("rx_bounded", lambda: pin.JointModelRX(), (-1.0, 2.0)),
    ("ry_unbounded", lambda: pin.JointModelRY(), None),
    ("rz_bounded", lambda: pin.JointModelRZ(), (-0.5, 0.5)),
    ("revolute_unaligned", lambda: pin.JointModelRevoluteUnaligned(AXIS), (-2.0, 1.0)),
    ("px_bounded", lambda: pin.JointModelPX(), (-0.3, 0.4)),
    ("pz_unbounded", lambda: pin.JointModelPZ(), None),
    ("prismatic_unaligned", lambda: pin.JointModelPrismaticUnaligned(AXIS), (0.0, 1.0)),
    ("rubx", lambda: pin.JointModelRUBX(), None),
    ("ruby", lambda: pin.JointModelRUBY(), None),
    ("rubz", lambda: pin.JointModelRUBZ(), None),
    ("rub_unaligned", lambda: pin.JointModelRevoluteUnboundedUnaligned(), None),
    ("spherical", lambda: pin.JointModelSpherical(), None),
    ("spherical_zyx", lambda: pin.JointModelSphericalZYX(), (-1.0, 1.0)),
    ("planar", lambda: pin.JointModelPlanar(), None),
    ("translation", lambda: pin.JointModelTranslation(), (-0.2, 0.2)),
    ("free_flyer", lambda: pin.JointModelFreeFlyer(), None),
]
NORMALIZED = {"rubx", "ruby", "rubz", "rub_unaligned", "spherical", "planar", "free_flyer"}
RUB_TYPES = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
UNIT_COMPLEX = {"rubx", "ruby", "rubz", "rub_unaligned"}


def _model(joint: pin.JointModel, limits: tuple[float, float] | None) -> pin.Model:
    """A two-joint chain: the joint under test, then a bounded revolute after it."""
    model = pin.Model()
    big = np.full(joint.nq, np.inf)
    lo = np.full(joint.nq, limits[0]) if limits else -big
    hi = np.full(joint.nq, limits[1]) if limits else big
    effort = np.full(joint.nv, 10.0)
    velocity = np.full(joint.nv, 2.0)
    j1 = model.addJoint(0, joint, pin.SE3.Identity(), "j_test", effort, velocity, lo, hi)
    inertia = pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3)
    model.appendBodyToJoint(j1, inertia, pin.SE3.Identity())
    placement = pin.SE3(np.eye(3), np.array([0.3, 0.1, 0.0]))
    j2 = model.addJoint(
        j1,
        pin.JointModelRY(),
        placement,
        "j_after",
        np.ones(1),
        np.ones(1),
        -np.ones(1),
        np.ones(1),
    )
    model.appendBodyToJoint(j2, inertia, pin.SE3.Identity())
    return model


def _robot(name: str) -> Robot:
    _, make, limits = next(j for j in JOINTS if j[0] == name)
    model = _model(make(), limits)
    empty = pin.GeometryModel()
    return Robot(model, empty, empty.copy(), name=name)


def _angle(q: np.ndarray, idx: int) -> float:
    return math.atan2(q[idx + 1], q[idx])


@pytest.mark.parametrize("name", [j[0] for j in JOINTS])
def test_neutral_and_random_configurations_are_normalized(name: str) -> None:
    robot = _robot(name)
    np.testing.assert_array_equal(robot.neutral(), pin.neutral(robot.model))
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = robot.random_configuration(rng)
        assert pin.isNormalized(robot.model, q, 1e-12)
        robot.check_configuration(q)
        robot.check_limits(q)


@pytest.mark.parametrize("name", sorted(NORMALIZED))
def test_unnormalized_blocks_are_rejected(name: str) -> None:
    robot = _robot(name)
    q = robot.random_configuration(np.random.default_rng(1))
    joint = robot.model.joints[1]
    start = joint.idx_q + {"planar": 2, "free_flyer": 3}.get(name, 0)
    size = 2 if name in UNIT_COMPLEX or name == "planar" else 4
    bad = q.copy()
    bad[start : start + size] *= 1.1
    assert not pin.isNormalized(robot.model, bad, 1e-6)
    kind = "unit complex" if size == 2 else "quaternion"
    with pytest.raises(InvalidInputError, match=rf"{kind}.*joint 'j_test'.*robot.normalize"):
        robot.check_configuration(bad)
    with pytest.raises(InvalidInputError):
        robot.state(bad)
    fixed = robot.normalize(bad)
    np.testing.assert_allclose(fixed, pin.normalize(robot.model, bad))
    robot.check_configuration(fixed)
    # a zero block has no direction: a clear error, not NaN
    zero = q.copy()
    zero[start : start + size] = 0.0
    with pytest.raises(InvalidInputError, match="zero"):
        robot.normalize(zero)


def test_acceptance_agrees_with_pinocchio() -> None:
    """check_configuration accepts exactly what pin.isNormalized accepts (away from the tol)."""
    robot = _robot("free_flyer")
    rng = np.random.default_rng(2)
    for _ in range(200):
        q = robot.random_configuration(rng)
        q[3:7] *= 1.0 + rng.choice([-1, 1]) * 10 ** rng.uniform(-9, -3)
        expected = pin.isNormalized(robot.model, q, 1e-6)
        try:
            robot.check_configuration(q)
            accepted = True
        except InvalidInputError:
            accepted = False
        assert accepted == expected


@pytest.mark.parametrize("name", [*sorted(UNIT_COMPLEX), "planar"])
def test_random_angles_cover_the_circle(name: str) -> None:
    robot = _robot(name)
    idx = robot.model.joints[1].idx_q + (2 if name == "planar" else 0)
    rng = np.random.default_rng(3)
    angles = np.array([_angle(robot.random_configuration(rng), idx) for _ in range(400)])
    counts, _ = np.histogram(angles, bins=8, range=(-np.pi, np.pi))
    # uniform: 50 per bin; each bin between 25 and 75 (probability of failure < 1e-4)
    assert counts.min() > 25 and counts.max() < 75, counts


@pytest.mark.parametrize("name", ["ry_unbounded", "pz_unbounded", "planar", "free_flyer"])
def test_unbounded_coordinates_are_sampled(name: str) -> None:
    robot = _robot(name)
    rng = np.random.default_rng(4)
    qs = np.array([robot.random_configuration(rng, base_box=2.0) for _ in range(300)])
    idx = robot.model.joints[1].idx_q
    first = qs[:, idx]
    if name == "ry_unbounded":
        assert first.min() < -3.0 and first.max() > 3.0 and np.abs(first).max() <= np.pi
    else:
        assert first.min() < -1.8 and first.max() > 1.8 and np.abs(first).max() <= 2.0


@pytest.mark.parametrize("name", ["rx_bounded", "revolute_unaligned", "px_bounded", "translation"])
def test_bounded_coordinates_cover_their_range(name: str) -> None:
    robot = _robot(name)
    _, _, (lo, hi) = next(j for j in JOINTS if j[0] == name)
    rng = np.random.default_rng(5)
    qs = np.array([robot.random_configuration(rng) for _ in range(300)])
    idx = robot.model.joints[1].idx_q
    span = hi - lo
    assert qs[:, idx].min() < lo + 0.05 * span and qs[:, idx].max() > hi - 0.05 * span
    assert qs[:, idx].min() >= lo and qs[:, idx].max() <= hi


@pytest.mark.parametrize("name", [j[0] for j in JOINTS])
def test_interpolate_and_distance_match_pinocchio(name: str) -> None:
    robot = _robot(name)
    rng = np.random.default_rng(6)
    for _ in range(10):
        q0 = robot.random_configuration(rng)
        q1 = robot.random_configuration(rng)
        for t in (0.0, 0.3, 1.0):
            q = robot.interpolate(q0, q1, t)
            np.testing.assert_allclose(q, pin.interpolate(robot.model, q0, q1, t), atol=1e-12)
            assert pin.isNormalized(robot.model, q, 1e-9)
        end = robot.interpolate(q0, q1, 1.0)  # q1, up to the sign of a quaternion
        np.testing.assert_allclose(pin.difference(robot.model, end, q1), 0.0, atol=1e-9)
        d = robot.distance(q0, q1)
        assert d == pytest.approx(np.linalg.norm(pin.difference(robot.model, q0, q1)), abs=1e-12)
        assert d == pytest.approx(pin.distance(robot.model, q0, q1), abs=1e-9)


@pytest.mark.parametrize("name", sorted(UNIT_COMPLEX))
def test_continuous_joint_goes_the_short_way(name: str) -> None:
    """Independent reference: angles 3.0 and -3.0 are 2 pi - 6 apart through +-pi."""
    robot = _robot(name)
    q0 = robot.neutral()
    q1 = robot.neutral()
    q0[0:2] = (math.cos(3.0), math.sin(3.0))
    q1[0:2] = (math.cos(-3.0), math.sin(-3.0))
    assert robot.distance(q0, q1) == pytest.approx(2 * math.pi - 6.0, abs=1e-12)
    mid = robot.interpolate(q0, q1, 0.5)
    assert abs(abs(_angle(mid, 0)) - math.pi) < 1e-12
    assert robot.difference(q0, q1)[0] == pytest.approx(2 * math.pi - 6.0, abs=1e-12)


@pytest.mark.parametrize("name", sorted(UNIT_COMPLEX))
@pytest.mark.parametrize("gap", [math.pi, math.pi - 1e-9, -(math.pi - 1e-9), math.pi - 1e-7])
def test_continuous_joint_turns_between_opposite_angles(name: str, gap: float) -> None:
    """Independent reference: the angle moves by t times the gap (pin.interpolate stays at q0)."""
    robot = _robot(name)
    q0 = robot.neutral()
    q1 = robot.neutral()
    q0[0:2] = (math.cos(0.4), math.sin(0.4))
    q1[0:2] = (math.cos(0.4 + gap), math.sin(0.4 + gap))
    turned = abs(robot.difference(q0, q1)[0])
    assert turned == pytest.approx(abs(gap), abs=1e-6)
    for t in (0.25, 0.5, 0.75):
        q = robot.interpolate(q0, q1, t)
        assert math.hypot(q[0], q[1]) == pytest.approx(1.0, abs=1e-12)
        moved = abs(math.remainder(_angle(q, 0) - 0.4, 2 * math.pi))
        assert moved == pytest.approx(t * turned, abs=1e-6)


def test_limits_apply_to_bounded_joints_only() -> None:
    robot = _robot("rx_bounded")
    q = robot.neutral()
    q[0] = 2.5
    with pytest.raises(LimitError, match=r"j_test=2\.5 not in"):
        robot.check_limits(q)
    continuous = _robot("rubz")
    q = continuous.neutral()
    q[0:2] = (-1.0, 0.0)  # angle pi: no limit on a continuous joint
    continuous.check_limits(q)
    assert list(continuous.limited_joints_q) == [2]  # only j_after
    ball = _robot("spherical_zyx")
    assert list(ball.limited_joints_q) == [0, 1, 2, 3]
    assert list(ball.limited_joints_v) == [0, 1, 2, 3]


def test_composite_joint_with_unit_complex_is_refused() -> None:
    composite = pin.JointModelComposite(pin.JointModelRUBZ())
    composite.addJoint(pin.JointModelRX())
    model = pin.Model()
    model.addJoint(0, composite, pin.SE3.Identity(), "combo")
    with pytest.raises(ModelLoadError, match=r"joint 'combo'.*does not support"):
        Robot(model, pin.GeometryModel(), pin.GeometryModel(), name="combo")


def test_interpolate_rejects_bad_fraction() -> None:
    robot = _robot("rubz")
    q = robot.neutral()
    for t in (math.nan, math.inf, "0.5", None):
        with pytest.raises(InvalidInputError, match="t must be a finite number"):
            robot.interpolate(q, q, t)  # type: ignore[arg-type]


# ---------------------------------------------------------------------- real robots
@pytest.fixture(scope="module")
def kinova() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_robot("kinova")


@pytest.fixture(scope="module")
def tiago() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_robot("tiago_no_hand")


def _continuous_blocks(robot: Robot) -> list[tuple[str, int]]:
    return [
        (str(robot.model.names[j]), int(robot.model.joints[j].idx_q))
        for j in range(1, robot.model.njoints)
        if robot.model.joints[j].shortname()
        in ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
    ]


@pytest.mark.parametrize("which", ["kinova", "tiago"])
def test_erd_continuous_joints(which: str, request: pytest.FixtureRequest) -> None:
    robot: Robot = request.getfixturevalue(which)
    blocks = _continuous_blocks(robot)
    assert blocks, "expected continuous (RUB) joints"
    jname, idx = blocks[0]
    q = robot.q_default.copy()
    q[idx : idx + 2] = (0.6, 0.6)  # norm 0.85: used to be accepted
    with pytest.raises(InvalidInputError, match=rf"unit complex.*joint '{jname}'"):
        robot.check_configuration(q)
    rng = np.random.default_rng(7)
    qs = [robot.random_configuration(rng) for _ in range(200)]
    assert all(pin.isNormalized(robot.model, x, 1e-12) for x in qs)
    for _, i in blocks:
        angles = np.array([_angle(x, i) for x in qs])
        counts, _ = np.histogram(angles, bins=4, range=(-np.pi, np.pi))
        assert counts.min() > 25, counts  # every quadrant is sampled (50 expected)
    for a, b in zip(qs[:5], qs[5:10]):
        np.testing.assert_allclose(
            robot.interpolate(a, b, 0.4), pin.interpolate(robot.model, a, b, 0.4), atol=1e-12
        )


@settings(max_examples=60)
@given(
    name=st.sampled_from([j[0] for j in JOINTS]),
    seed=st.integers(0, 2**32 - 1),
    t=st.floats(0.0, 1.0),
)
def test_interpolation_is_a_constant_speed_geodesic(name: str, seed: int, t: float) -> None:
    """``difference(q0, interpolate(q0, q1, t)) = t difference(q0, q1)``; distance symmetric."""
    robot = _robot(name)
    rng = np.random.default_rng(seed)
    q0, q1 = robot.random_configuration(rng), robot.random_configuration(rng)
    qt = robot.interpolate(q0, q1, t)
    robot.check_configuration(qt)
    np.testing.assert_allclose(
        robot.difference(q0, qt), t * robot.difference(q0, q1), atol=1e-9, rtol=1e-9
    )
    assert robot.distance(q0, q1) == pytest.approx(robot.distance(q1, q0), abs=1e-9)
    assert robot.distance(q0, qt) == pytest.approx(t * robot.distance(q0, q1), abs=1e-9)
