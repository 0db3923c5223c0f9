"""New-user inputs to certify_path: robots with continuous joints, bad caps."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning.certify import certify_path


@pytest.fixture(scope="module")
def kinova() -> Robot:
    return Robot.load("kinova")


def _pinocchio_min_distance(robot: Robot, q: np.ndarray) -> float:
    data, gd = robot.model.createData(), robot.collision_model.createData()
    pin.computeDistances(robot.model, data, robot.collision_model, gd, q)
    return min(r.min_distance for r in gd.distanceResults)


def test_continuous_joints_are_interpolated_on_the_circle(kinova: Robot) -> None:
    # The Kinova arm has continuous joints (nq 9 > nv 6): the segment is q0 (+) t (q1 (-) q0).
    assert kinova.nq > kinova.model.nv
    q0 = kinova.q_default
    dv = np.zeros(kinova.model.nv)
    dv[0] = 0.2  # the first joint is continuous
    q1 = pin.integrate(kinova.model, q0, dv)
    cert = certify_path(kinova, np.array([q0, q1]), max_queries=5000)
    # The least distance along the path is at most the distance at either end (Pinocchio).
    ends = min(_pinocchio_min_distance(kinova, q0), _pinocchio_min_distance(kinova, q1))
    assert cert.min_distance <= ends + 1e-12
    assert cert.distance_queries >= 1


@pytest.mark.parametrize("max_queries", [0, -1, 2.5, True])
def test_bad_query_cap_is_refused(kinova: Robot, max_queries: object) -> None:
    q0 = kinova.q_default
    with pytest.raises(InvalidInputError, match="max_queries"):
        certify_path(kinova, np.array([q0, q0]), max_queries=max_queries)  # type: ignore[arg-type]
