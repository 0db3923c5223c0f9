"""MechanicalWork of a continuous joint turned by half a turn.

The geodesic of the work was ``pinocchio.interpolate``, which stays at ``a`` on a continuous
joint whose angles at ``a`` and ``b`` are opposite: the work of lifting a mass by the half
turn was 0 J, so a planner minimizing work found such segments free. Reference by hand: a
1 kg point mass 1 m from a wheel about y, from the top (angle -pi/2, height +1 m) half a turn
to the bottom, moves its height monotonically by 2 m whichever way it turns: 2 m g [J].
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.planning import MechanicalWork


def _wheel_with_a_mass() -> pin.Model:
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRUBY(), pin.SE3.Identity(), "wheel")
    inertia = pin.Inertia(1.0, np.array([1.0, 0.0, 0.0]), np.eye(3) * 1e-9)
    model.appendBodyToJoint(j, inertia, pin.SE3.Identity())
    return model


def _at(theta: float) -> np.ndarray:
    return np.array([math.cos(theta), math.sin(theta)])


@pytest.mark.parametrize("turn", [math.pi - 1e-3, math.pi - 1e-7, math.pi, -math.pi + 1e-9])
def test_half_a_turn_lifts_the_mass_by_two_metres(turn: float) -> None:
    model = _wheel_with_a_mass()
    g = float(np.linalg.norm(model.gravity.linear))
    top = -math.pi / 2  # the mass at [cos, 0, -sin] = [0, 0, 1]
    work = MechanicalWork(model, resolution=0.05).path_cost(np.stack([_at(top), _at(top + turn)]))
    height = 1.0 - math.sin(-(top + turn))  # drop of the mass [m]
    assert height == pytest.approx(2.0, abs=1e-6)
    assert work == pytest.approx(g * height, rel=2e-3)  # the midpoint rule's error
