"""Stability and ZMP helpers given bad inputs (audit of session 30): a named error, never NaN."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import (
    ContactWrench,
    SupportPolygon,
    straight_walk,
    support_polygon_at,
    support_polygons,
    total_wrench,
    zmp_from_wrenches,
    zmp_reference,
)


def test_contact_wrench_made_directly_is_checked_like_its_factories():
    # by hand: two vertical forces of 10 N and 30 N at x = 0 and x = 0.4: ZMP at x = 0.3
    wrenches = [
        ContactWrench([0.0, 0.0, 0.0], [0.0, 0.0, 10.0], [0.0, 0.0, 0.0]),
        ContactWrench(np.array([0.4, 0.2, 0.0], dtype=np.float32), (0, 0, 30), np.zeros(3)),
    ]
    assert zmp_from_wrenches(wrenches) == pytest.approx([0.3, 0.15, 0.0], abs=1e-7)
    assert wrenches[1].point.dtype == np.float64
    for bad in (
        dict(point=np.zeros(3), force=[0.0, 0.0, np.nan], torque=np.zeros(3)),
        dict(point=np.zeros(3), force=[0.0, 0.0, 1.0], torque=[np.inf, 0.0, 0.0]),
        dict(point=np.zeros(2), force=[0.0, 0.0, 1.0], torque=np.zeros(3)),
    ):
        with pytest.raises(InvalidInputError):
            ContactWrench(**bad)


def test_total_wrench_names_a_wrong_item_and_an_overflow():
    good = ContactWrench.point_force([0.0, 0.0, 0.0], [0.0, 0.0, 10.0])
    with pytest.raises(InvalidInputError, match=r"wrenches\[1\] must be a ContactWrench"):
        total_wrench([good, ([0.0, 0.0, 0.0], [0.0, 0.0, 10.0])])
    huge = ContactWrench.point_force([0.0, 0.0, 0.0], [0.0, 0.0, 1e308])
    with pytest.raises(InvalidInputError, match="overflows"):
        zmp_from_wrenches([huge, huge])


def test_margin_of_a_point_with_too_few_coordinates_is_a_named_error():
    square = SupportPolygon.from_points([[0, 0], [1, 0], [1, 1], [0, 1]])
    assert square.margin([0.5, 0.25]) == pytest.approx(0.25)
    assert square.margin([0.5, 0.25, 9.0]) == pytest.approx(0.25)
    for bad in ([0.5], [0.5, 0.5, 0.0, 1.0]):
        with pytest.raises(InvalidInputError, match="ground point"):
            square.margin(bad)
        with pytest.raises(InvalidInputError, match="ground point"):
            square.contains(bad)


def test_reference_at_a_nan_time_is_a_named_error():
    plan = straight_walk(3)
    assert zmp_reference(plan, [0.0, 1e6]).shape == (2, 2)
    for call in (
        lambda: zmp_reference(plan, [0.0, np.nan]),
        lambda: support_polygons(plan, [np.inf]),
        lambda: support_polygon_at(plan, float("nan")),
    ):
        with pytest.raises(InvalidInputError):
            call()
