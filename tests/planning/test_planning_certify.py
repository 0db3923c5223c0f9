"""Certified paths: conservative advancement against dense coal checks."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning.certify import certify_path, motion_bounds


@pytest.fixture(scope="module")
def panda() -> Robot:
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.box("block", [0.1, 0.4, 0.3], [0.45, 0.0, 0.35]))
    return robot


def dense_min_distance(robot: Robot, q0: np.ndarray, q1: np.ndarray, n: int = 400) -> float:
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    least = np.inf
    for t in np.linspace(0, 1, n):
        pin.computeDistances(model, data, gm, gd, q0 + t * (q1 - q0))
        least = min(least, min(r.min_distance for r in gd.distanceResults))
    return float(least)


def test_motion_bound_holds_for_every_geometry_point(panda: Robot) -> None:
    R = motion_bounds(panda)
    model, gm = panda.model, panda.collision_model
    rng = np.random.default_rng(0)
    corners_local = []
    for k in range(panda.robot_geometry_count):
        g = gm.geometryObjects[k].geometry
        g.computeLocalAABB()
        lo, hi = g.aabb_local.min_, g.aabb_local.max_
        corners_local.append(
            np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
        )
    for _ in range(20):
        q = panda.random_configuration(rng)
        j = int(rng.integers(model.nv))
        dq = np.zeros(model.nv)
        dq[j] = 1e-3
        moved = 0.0
        for q_a, q_b in ((q, q + dq),):
            da, db = model.createData(), model.createData()
            gda, gdb = gm.createData(), gm.createData()
            pin.updateGeometryPlacements(model, da, gm, gda, q_a)
            pin.updateGeometryPlacements(model, db, gm, gdb, q_b)
            for k, corners in enumerate(corners_local):
                pa = corners @ gda.oMg[k].rotation.T + gda.oMg[k].translation
                pb = corners @ gdb.oMg[k].rotation.T + gdb.oMg[k].translation
                moved = max(moved, float(np.max(np.linalg.norm(pb - pa, axis=1))))
        assert moved <= R[j] * 1e-3 + 1e-12


def test_certified_segments_are_free_densely_and_colliding_ones_are_not_certified(
    panda: Robot,
) -> None:
    rng = np.random.default_rng(1)
    certified = refused = 0
    for _ in range(12):
        q0, q1 = panda.random_configuration(rng), panda.random_configuration(rng)
        cert = certify_path(panda, np.array([q0, q1]))
        dense = dense_min_distance(panda, q0, q1)
        if cert.certified:
            certified += 1
            assert dense > 0.0
            assert cert.min_distance >= 1e-4
        else:
            refused += 1
            assert cert.failed_segment == 0
        if dense <= 0.0:
            assert not cert.certified
    assert certified >= 1 and refused >= 1


def test_path_through_the_block_fails_at_that_segment(panda: Robot) -> None:
    q_free = panda.q_default.copy()
    through = q_free.copy()
    through[0] += 0.05
    # move the hand into the block: a configuration whose tcp is inside it
    rng = np.random.default_rng(2)
    inside = None
    for _ in range(2000):
        q = panda.random_configuration(rng)
        if dense_min_distance(panda, q, q, n=1) < -0.01:
            inside = q
            break
    assert inside is not None
    cert = certify_path(panda, np.array([q_free, through, inside]))
    assert not cert.certified and cert.failed_segment == 1 and cert.min_distance < 1e-4
    with pytest.raises(InvalidInputError):
        certify_path(panda, np.zeros((2, 3)))
