"""One interpolation of configurations, on every joint type, checked against Pinocchio.

``Robot.interpolate``, ``JointManifold.interpolate`` (hence every planner's
``ConfigurationSpace.interpolate``) and the certification all compute
``q0 (+) t (q1 (-) q0)`` by ``taskspace.model.robot.interpolate_configurations``. The
reference is ``pin.interpolate`` on normalized inputs; the two cases where Pinocchio is wrong
get references written by hand: opposite angles of a continuous joint (``pin.interpolate``
stays at ``q0``) and unit complexes of norm ``1 +- 5e-7`` (accepted inputs, on which
Pinocchio's SO(2) logarithm returns 0 for nearby angles).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold


def _hand_built() -> Robot:
    """Planar root, spherical, continuous (RUBZ) and revolute joints: a model built by hand."""
    model = pin.Model()
    rng = np.random.default_rng(7)
    placements = [pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))]
    j = model.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "base")
    j = model.addJoint(j, pin.JointModelSpherical(), placements[0], "ball")
    j = model.addJoint(j, pin.JointModelRUBZ(), placements[0], "wheel")
    model.addJoint(
        j,
        pin.JointModelRX(),
        placements[0],
        "elbow",
        np.array([10.0]),
        np.array([10.0]),
        np.array([-2.0]),
        np.array([2.0]),
    )
    for k in range(1, model.njoints):
        body = pin.Inertia.FromSphere(1.0, 0.1)
        model.appendBodyToJoint(k, body, pin.SE3.Identity())
    return Robot(model, pin.GeometryModel(), pin.GeometryModel(), name="hand_built")


def _free_flyer_spherical() -> Robot:
    """Free-flyer root and a spherical joint, built by hand."""
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    model.addJoint(j, pin.JointModelSpherical(), pin.SE3(np.eye(3), np.array([0.3, 0, 0])), "ball")
    for k in range(1, model.njoints):
        model.appendBodyToJoint(k, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    return Robot(model, pin.GeometryModel(), pin.GeometryModel(), name="ff_ball")


def _load(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name == "tiago":  # planar base and two continuous wheels
            return Robot.load("tiago", base="planar", geometry=False)
        if name == "solo12":  # free flyer
            return Robot.load("solo12", geometry=False)
        return {"hand_built": _hand_built, "ff_ball": _free_flyer_spherical}[name]()


ROBOTS = ("tiago", "solo12", "hand_built", "ff_ball")


@pytest.fixture(scope="module", params=ROBOTS)
def robot_and_manifold(request: pytest.FixtureRequest) -> tuple[Robot, JointManifold]:
    robot = _load(request.param)
    n_t = {"JointModelPlanar": 2, "JointModelFreeFlyer": 3}[robot.model.joints[1].shortname()]
    manifold = JointManifold(robot, base_lower=[-2.0] * n_t, base_upper=[2.0] * n_t)
    return robot, manifold


def test_every_joint_type_is_present() -> None:
    kinds = {b.kind for name in ROBOTS for b in _manifold_of(_load(name)).blocks}
    assert kinds == {"vector", "circle", "planar", "spherical", "free_flyer"}


def _manifold_of(robot: Robot) -> JointManifold:
    n_t = {"JointModelPlanar": 2, "JointModelFreeFlyer": 3}[robot.model.joints[1].shortname()]
    return JointManifold(robot, base_lower=[-2.0] * n_t, base_upper=[2.0] * n_t)


TS = np.array([0.0, 0.1, 0.25, 0.5, 0.8, 1.0])


def test_robot_space_and_manifold_interpolate_as_pinocchio(
    robot_and_manifold: tuple[Robot, JointManifold],
) -> None:
    robot, manifold = robot_and_manifold
    model = robot.model
    n_t = 2 if model.joints[1].shortname() == "JointModelPlanar" else 3
    space = ConfigurationSpace.from_robot(robot, base_lower=[-2.0] * n_t, base_upper=[2.0] * n_t)
    rng = np.random.default_rng(3)
    samples = manifold.sample(rng, 60)
    for q0, q1 in zip(samples[::2], samples[1::2]):
        ours = manifold.interpolate(q0, q1, TS)
        for k, t in enumerate(TS.tolist()):
            reference = pin.interpolate(model, q0, q1, t)
            np.testing.assert_allclose(ours[k], reference, atol=1e-12)
            # one implementation: the robot's answer is the manifold's, bit for bit
            assert np.array_equal(robot.interpolate(q0, q1, t), ours[k])
        assert np.array_equal(space.interpolate(q0, q1, TS), ours)


def _unit_parts(manifold: JointManifold) -> list[slice]:
    out = []
    for b in manifold.blocks:
        start = {"circle": 0, "planar": 2, "spherical": 0, "free_flyer": 3}.get(b.kind)
        if start is not None:
            out.append(slice(b.idx_q + start, b.idx_q + b.nq))
    return out


def test_unit_parts_off_by_5e_7_interpolate_as_their_normalized_selves(
    robot_and_manifold: tuple[Robot, JointManifold],
) -> None:
    """Accepted inputs (within 1e-6 of unit norm) 1e-4 rad apart: Pinocchio's difference of
    (cos, sin) pairs of norm 1 + 5e-7 is 0 (and ``pin.interpolate`` stays at q0); ours moves
    as ``pin.interpolate`` of the normalized inputs."""
    robot, manifold = robot_and_manifold
    model = robot.model
    rng = np.random.default_rng(5)
    parts = _unit_parts(manifold)
    for _ in range(10):
        q0 = manifold.sample(rng, 1)[0]
        q1 = pin.integrate(model, q0, rng.uniform(-1e-4, 1e-4, model.nv))
        for sl in parts:
            q0[sl] *= 1.0 + 5e-7
            q1[sl] *= 1.0 + 5e-7
        robot.check_configuration(q0)  # accepted
        n0, n1 = pin.normalize(model, q0), pin.normalize(model, q1)
        ours = manifold.interpolate(q0, q1, TS)
        for k, t in enumerate(TS.tolist()):
            reference = pin.interpolate(model, n0, n1, t)
            np.testing.assert_allclose(ours[k], reference, atol=1e-12)
            np.testing.assert_allclose(robot.interpolate(q0, q1, t), reference, atol=1e-12)


def test_opposite_wheel_angles_turn_by_half_a_turn() -> None:
    """Hand-written reference: the wheel's angle is q0's plus t pi (pin.interpolate: q0's)."""
    robot = _load("tiago")
    manifold = _manifold_of(robot)
    model = robot.model
    wheel = model.joints[model.getJointId("wheel_left_joint")].idx_q
    q0 = manifold.sample(np.random.default_rng(1), 1)[0]
    q1 = q0.copy()
    a0 = 0.3
    q0[wheel : wheel + 2] = [math.cos(a0), math.sin(a0)]
    q1[wheel : wheel + 2] = [math.cos(a0 + math.pi), math.sin(a0 + math.pi)]
    points = manifold.interpolate(q0, q1, TS)
    for k, t in enumerate(TS.tolist()):
        angle = math.atan2(points[k, wheel + 1], points[k, wheel])
        turned = math.remainder(angle - a0, 2 * math.pi)
        assert abs(abs(turned) - t * math.pi) < 1e-9, (t, turned)
        assert np.array_equal(robot.interpolate(q0, q1, t), points[k])
