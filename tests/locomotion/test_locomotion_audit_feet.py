"""Feet given to the support polygon in other forms (audit of session 30)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from taskspace.errors import InvalidInputError
from taskspace.locomotion import (
    ContactKind,
    FootGeometry,
    robot_feet,
    static_stability,
    support_polygon,
)

SOLO_FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


def _point_foot(frame):
    return FootGeometry(frame=frame, vertices=np.zeros((1, 3)), kind=ContactKind.POINTS)


def test_solo12_on_point_feet_against_scipy_and_pinocchio(robot_loader):
    solo = robot_loader("solo12")
    q = solo.q_default
    feet = [_point_foot(f) for f in SOLO_FEET]
    result = static_stability(solo, q, feet)
    points = np.array([solo.frame_placement(q, f).translation[:2] for f in SOLO_FEET])
    hull = ConvexHull(points)
    com = pin.centerOfMass(solo._model, solo._model.createData(), q)
    expected = float(np.min(-(hull.equations[:, :2] @ com[:2] + hull.equations[:, 2])))
    assert result.stable
    assert result.margin == pytest.approx(expected, abs=1e-12)
    assert result.com == pytest.approx(com, abs=1e-12)


def test_feet_as_one_foot_or_the_robot_feet_dict(talos):
    feet = robot_feet("talos")
    q = talos.q_default
    both = support_polygon(talos, q, list(feet.values()))
    assert np.array_equal(support_polygon(talos, q, feet).vertices, both.vertices)
    assert np.array_equal(support_polygon(talos, q, feet.values()).vertices, both.vertices)
    left = support_polygon(talos, q, [feet["left"]])
    assert np.array_equal(support_polygon(talos, q, feet["left"]).vertices, left.vertices)
    assert static_stability(talos, q, feet).margin == pytest.approx(
        static_stability(talos, q, list(feet.values())).margin
    )


def test_feet_that_are_not_foot_geometries_are_named(talos):
    q = talos.q_default
    for bad, match in (
        (["left_sole_link"], r"feet\[0\] must be a FootGeometry"),
        ("left_sole_link", "feet must be a list of FootGeometry"),
        (3, "feet must be a list of FootGeometry"),
        ([], "at least one foot"),
    ):
        with pytest.raises(InvalidInputError, match=match):
            support_polygon(talos, q, bad)
        with pytest.raises(InvalidInputError, match=match):
            static_stability(talos, q, bad)
