"""A mobile manipulator as a new user loads it: ``Robot.load("tiago", base="planar")``.

The base (x, y, yaw on a Pinocchio ``JointModelPlanar``) and the arm are planned together
around a wall; the returned path is certified by the planner and checked again densely by
Pinocchio's ``computeCollisions`` on the interpolated configurations (independent of the
planner's checker and of the certification).
"""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import taskspace
from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

URDF = Path(taskspace.__file__).parent / "robots_data" / "urdf" / "planar_2link.urdf"


def _tiago_planar() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tiago's hand pairs in contact at its posture
        return Robot.load("tiago", base="planar", convex_collision=True)


def _dense_collisions(robot: Robot, path: np.ndarray, step: float) -> int:
    """Configurations of Pinocchio's interpolation (every ``step`` in the tangent norm) that
    Pinocchio's computeCollisions reports in collision."""
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    hits = 0
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.linalg.norm(pin.difference(model, a, b)) / step)))
        for t in np.linspace(0.0, 1.0, n + 1):
            q = pin.interpolate(model, a, b, t)
            hits += bool(pin.computeCollisions(model, data, geom, gdata, q, True))
    return hits


@pytest.mark.slow
def test_tiago_base_and_arm_go_around_a_wall_on_a_certified_path() -> None:
    robot = _tiago_planar()
    model = robot.model
    assert model.joints[1].shortname() == "JointModelPlanar"
    robot.add_obstacle(Obstacle.box("wall", [0.3, 1.6, 1.0], [0.0, 0.0, 0.5]))
    space = ConfigurationSpace.from_robot(robot, base_lower=[-3, -3], base_upper=[3, 3])
    start, goal = robot.q_default.copy(), robot.q_default.copy()
    start[:4] = [-1.5, 0.0, 1.0, 0.0]  # x, y, cos, sin of the base
    goal[:4] = [1.5, 0.0, 0.0, 1.0]  # the other side of the wall, turned 90 degrees
    arm = [model.joints[model.getJointId(f"arm_{i}_joint")].idx_q for i in range(1, 8)]
    goal[arm] = np.clip(
        goal[arm] + [0.8, 0.5, -0.5, 0.8, 0.5, 0.3, 0.4], space.lower[arm], space.upper[arm]
    )
    assert not space.motion_valid(start, goal)  # the wall is in the way
    # tiago's finger phalanges are 10-20 um apart at any posture of its hand (its meshes),
    # under the certification's 0.1 mm margin: the hand's pairs among its own links go.
    hand = [
        (a, b) for a, b in robot.collision_pairs if a.startswith("hand_") and b.startswith("hand_")
    ]
    robot.disable_collision_pairs(hand)
    opts = RRTConnectOptions(time_limit_s=30.0, seed=0, certify=True)
    result = rrt_connect(space, start, goal, opts)
    assert result.success and result.log["certified"] == 1.0
    assert result.log["min_distance"] > 0.0
    path = result.path
    np.testing.assert_allclose(path[0], start)
    np.testing.assert_allclose(path[-1], goal)
    assert max(space.manifold.unit_error(q) for q in path) < 1e-9
    dense = space.interpolate_path(path, 0.05)
    assert np.abs(dense[:, 1]).max() > 0.8  # the base went around the 1.6 m wall
    assert _dense_collisions(robot, path, 0.01) == 0


def test_base_option_builds_the_root_joint_and_refuses_bad_ones() -> None:
    fixed = Robot.load("ur5", geometry=False)
    planar = Robot.load("ur5", geometry=False, base="planar")
    free = Robot.load("ur5", geometry=False, base="free_flyer")
    assert planar.model.joints[1].shortname() == "JointModelPlanar"
    assert free.model.joints[1].shortname() == "JointModelFreeFlyer"
    assert (planar.nq, planar.nv) == (fixed.nq + 4, fixed.nv + 3)
    assert (free.nq, free.nv) == (fixed.nq + 7, fixed.nv + 6)
    # the planar root moves the whole arm: a base at (x, y, yaw) moves every frame by it
    q = planar.q_default.copy()
    yaw = 0.7
    q[:4] = [0.3, -0.2, np.cos(yaw), np.sin(yaw)]
    data = planar.model.createData()
    pin.framesForwardKinematics(planar.model, data, q)
    tool = planar.model.getFrameId("tool0")
    ref = fixed.model.createData()
    pin.framesForwardKinematics(fixed.model, ref, q[4:])
    base = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw), np.array([0.3, -0.2, 0.0]))
    expected = base * ref.oMf[fixed.model.getFrameId("tool0")]
    assert np.allclose(data.oMf[tool].homogeneous, expected.homogeneous, atol=1e-12)
    with pytest.raises(InvalidInputError, match="fixed, planar, free_flyer"):
        Robot.load("ur5", geometry=False, base="wheels")
    with pytest.raises(InvalidInputError, match="free_flyer=True contradicts"):
        Robot.from_urdf(URDF, free_flyer=True, base="planar", geometry=False)
    with pytest.raises(InvalidInputError, match="fixed, planar, free_flyer"):
        Robot.from_urdf(URDF, base="Planar", geometry=False)
