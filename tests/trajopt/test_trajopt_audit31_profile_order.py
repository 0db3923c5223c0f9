"""MotionProfile.derivative refuses orders outside 0..3 (audit 31).

The order is documented as 0 to 3; other orders were silently answered: SineProfile gave its
jerk for order -1 or 5, MinimumJerkProfile its jerk for order -1 (and an IndexError for 4),
RampProfile and the piecewise profiles 0 or their jerk, and order 1.5 a bare TypeError.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.trajopt import (
    MinimumJerkProfile,
    RampProfile,
    SCurveProfile,
    SineProfile,
    TrapezoidalProfile,
)

PROFILES = [
    RampProfile(),
    SineProfile(),
    MinimumJerkProfile(),
    TrapezoidalProfile(),
    SCurveProfile(),
]


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.name)
def test_orders_outside_zero_to_three_are_refused(profile):
    for bad in (-1, 4, 5, 1.5, True, "1", None):
        with pytest.raises(InvalidInputError, match="order"):
            profile.derivative(0.3, bad)


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.name)
def test_orders_zero_to_three_match_finite_differences(profile):
    s = np.linspace(0.05, 0.95, 7) + 1e-3  # away from the piecewise breaks
    h = 1e-6
    assert profile.derivative(np.float64(0.3), np.int64(2)) == profile.derivative(0.3, 2)
    for order in (1, 2, 3):
        fd = (profile.derivative(s + h, order - 1) - profile.derivative(s - h, order - 1)) / (2 * h)
        np.testing.assert_allclose(profile.derivative(s, order), fd, rtol=1e-4, atol=1e-4)
