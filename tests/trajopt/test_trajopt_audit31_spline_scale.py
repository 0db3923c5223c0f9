"""Splines over huge knot spacings are refused instead of silently wrong (audit 31).

A natural cubic spline is invariant under a scaling of its knots (q(c t) over knots c t_k
equals q(t) over t_k): through (0, 1, 0.5, 2) at knots (0, 1, 2, 3) it is 0.7125 at t = 1.5
(scipy's CubicSpline agrees). With knots scaled by 1e150 the power-basis coefficient of
(t - t_k)^3 (~ q / h^3) underflowed to 0 and evaluate(1.5e150) returned 0.5667 (1e200:
0.9667), without an error and, below 1e154, without a warning.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from taskspace.errors import InvalidInputError
from taskspace.trajopt import cubic_spline, quintic_spline

WAYPOINTS = np.array([[0.0], [1.0], [0.5], [2.0]])
KNOTS = np.array([0.0, 1.0, 2.0, 3.0])


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e3, 1e50, 1e90])
def test_scaled_knots_give_the_same_curve(scale):
    ref = CubicSpline(KNOTS, WAYPOINTS, bc_type="natural")(1.5)
    spline = cubic_spline(WAYPOINTS, KNOTS * scale)
    np.testing.assert_allclose(spline.evaluate([1.5 * scale]), [ref], rtol=1e-9)
    np.testing.assert_allclose(spline.waypoints, WAYPOINTS, atol=1e-12)


@pytest.mark.parametrize("scale", [1e150, 1e160, 1e200, 1e300])
@pytest.mark.parametrize("make", [cubic_spline, quintic_spline], ids=["cubic", "quintic"])
def test_knot_spacings_beyond_float64_coefficients_are_refused(make, scale):
    with pytest.raises(InvalidInputError, match="knot spacings"):
        make(WAYPOINTS, KNOTS * scale)
