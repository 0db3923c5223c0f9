"""walk() given a plan made for other feet (audit of session 30): refused before simulating."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import plan_from_robot, straight_walk, walk, walking_reference
from tests.locomotion._walking import SHORT_TIMING as TIMING


def test_a_plan_off_the_robots_feet_is_named(g1):
    good = plan_from_robot(g1, g1.q_default, 2, step_length=0.08, timing=TIMING)
    ref = walking_reference(g1, good, None)
    assert np.isfinite(ref.com).all()
    # G1's feet are 0.237 m apart: a plan 0.4 m wide made the simulated walk diverge and end
    # in "NotFiniteError: point has non-finite entries" from the ZMP margin of a NaN state
    wide = straight_walk(2, step_length=0.08, step_width=0.4, timing=TIMING)
    for call in (walk, walking_reference):
        with pytest.raises(InvalidInputError, match=r"initial left foot .*plan_from_robot"):
            call(g1, wide)
