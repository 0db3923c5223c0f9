"""Functions of a footstep plan given something else (audit of session 30)."""

from __future__ import annotations

import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import (
    mpc_walking_pattern,
    preview_walking_pattern,
    straight_walk,
    support_polygon_at,
    support_polygons,
    zmp_reference,
)


def test_a_plan_that_is_not_a_footstep_plan_is_named():
    plan = straight_walk(2)
    calls = (
        lambda p: zmp_reference(p, [0.0]),
        lambda p: support_polygons(p, [0.0]),
        lambda p: support_polygon_at(p, 0.0),
        lambda p: preview_walking_pattern(p),
        lambda p: mpc_walking_pattern(p),
    )
    for call in calls:
        call(plan)
        for bad in ("plan", plan.steps, None):
            with pytest.raises(InvalidInputError, match="plan must be a FootstepPlan"):
                call(bad)
