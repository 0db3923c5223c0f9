"""Continuous joints between opposite angles: the edge must turn, not stay at its start.

Pinocchio's SO(2) interpolation returns ``q0`` for every ``t`` when the two angles of a
continuous joint are opposite (to ~1e-6 rad), while ``pinocchio.difference`` says pi: an edge
of length pi whose checked points were all its start. Every planner then returned the
straight line from angle 0 to angle pi as SOLVED through a wall on either side, and
``interpolate_path`` jumped from ``q0`` to ``q1`` in one point.

References here are written by hand: the angle of a point is ``atan2(sin, cos)``, the edge
turns the short way (either way at exactly pi) and is checked every 0.005 rad against the
walls' angles themselves, not through the space.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.planning import (
    shortcut_path,
    smooth_bspline,
)
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold
from tests.planning._planning_worlds import PLANNERS


def _in_wall(angle: np.ndarray, walls: list[tuple[float, float]]) -> np.ndarray:
    a = np.asarray(angle)
    out = np.zeros(a.shape, bool)
    for lo, hi in walls:
        out |= (a >= lo) & (a <= hi)
    return out


def _wheel(walls: list[tuple[float, float]]) -> ConfigurationSpace:
    """One continuous joint; angles (atan2, in (-pi, pi]) inside a wall collide."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    manifold = JointManifold(model)

    def free(q: np.ndarray) -> np.ndarray:
        return ~_in_wall(np.arctan2(q[:, 1], q[:, 0]), walls)

    return ConfigurationSpace(
        manifold.lower, manifold.upper, FunctionChecker(free), manifold=manifold
    )


def _angle(q: np.ndarray) -> float:
    return math.atan2(q[1], q[0])


def _edge_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles every 0.005 rad from a to b, the short way (both ways at exactly pi)."""
    t0, t1 = _angle(a), _angle(b)
    turn = math.remainder(t1 - t0, 2 * math.pi)
    n = max(2, math.ceil(abs(turn) / 0.005) + 1)
    ways = [turn, -turn] if abs(abs(turn) - math.pi) < 1e-6 else [turn]
    out = [t0 + np.linspace(0.0, 1.0, n) * w for w in ways]
    return np.arctan2(np.sin(out), np.cos(out))  # (ways, n) in (-pi, pi]


def _free_densely(path: np.ndarray, walls: list[tuple[float, float]]) -> bool:
    """Every edge free every 0.005 rad (at exactly pi: free whichever way it turns)."""
    return all(
        not _in_wall(way, walls).any()
        for a, b in itertools.pairwise(path)
        for way in _edge_angles(a, b)
    )


def _at(theta: float) -> np.ndarray:
    return np.array([math.cos(theta), math.sin(theta)])


@pytest.mark.parametrize("turn", [math.pi, math.pi - 1e-9, -(math.pi - 1e-9), math.pi - 1e-7])
def test_interpolation_turns_between_opposite_angles(turn: float) -> None:
    space = _wheel([])
    q0 = _at(0.3)
    q1 = _at(0.3 + turn)
    ts = np.linspace(0.0, 1.0, 9)
    points = space.interpolate(q0, q1, ts)
    d = space.distance(q0, q1)
    assert d == pytest.approx(abs(turn), abs=1e-9)
    for t, q in zip(ts, points, strict=True):
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
        assert space.distance(q0, q) == pytest.approx(t * d, abs=1e-9)
        assert space.distance(q, q1) == pytest.approx((1 - t) * d, abs=1e-9)
    dense = space.interpolate_path(np.stack([q0, q1]), 0.1)
    steps = [space.distance(a, b) for a, b in itertools.pairwise(dense)]
    assert len(dense) == 33 and max(steps) <= 0.1 + 1e-12


def test_a_robot_with_a_continuous_joint_and_a_revolute_one() -> None:
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "arm")
    model.addJoint(j, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    model.lowerPositionLimit[0], model.upperPositionLimit[0] = -1.0, 1.0
    manifold = JointManifold(model)
    q0, q1 = np.array([-0.5, 1.0, 0.0]), np.array([0.5, -1.0, 0.0])  # the wheel turns by pi
    mid = manifold.interpolate(q0, q1, [0.5])[0]
    assert mid[0] == pytest.approx(0.0, abs=1e-15)
    assert abs(mid[2]) == pytest.approx(1.0)  # a quarter turn, either way


@pytest.mark.parametrize("name", PLANNERS)
def test_no_planner_goes_through_the_walls_on_both_sides(name: str) -> None:
    fn, options = PLANNERS[name]
    walls = [(1.0, 2.0), (-2.0, -1.0)]  # 0 and pi are not connected
    result = fn(
        _wheel(walls), _at(0.0), _at(math.pi), options(max_iterations=60, time_limit_s=None)
    )
    if isinstance(result, tuple):  # the PRMs return their roadmap too
        result = result[0]
    assert not result.success, result.path


@pytest.mark.parametrize("name", PLANNERS)
def test_planners_go_round_the_free_side(name: str) -> None:
    fn, options = PLANNERS[name]
    walls = [(0.5, 2.5)]  # from 0 to pi only through negative angles
    space = _wheel(walls)
    result = fn(space, _at(0.0), _at(math.pi), options(max_iterations=1000, time_limit_s=None))
    if isinstance(result, tuple):
        result = result[0]
    assert result.success
    assert _free_densely(result.path, walls)
    for smooth in (shortcut_path, smooth_bspline):
        path = smooth(space, result.path).path
        assert np.allclose(path[[0, -1]], result.path[[0, -1]], atol=1e-12)
        assert _free_densely(path, walls)
