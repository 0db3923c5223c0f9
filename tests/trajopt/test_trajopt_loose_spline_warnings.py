"""Splines beyond float64 are refused with one InvalidInputError and no numpy warning first
(audit4, left open: overflow/divide/invalid RuntimeWarnings came before the error), and a
spline whose coefficients are large but exact enough is not refused by rounding luck (a
quintic leaving (0, 1, 2) at velocity 1e10 was refused, at 1e12 accepted).

References: scipy's CubicSpline (clamped); for the C4 quintic, linearity of the spline in its
data, ``s[q, v0] = s[q, 0] + v0 s[0, 1]``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from taskspace.errors import InvalidInputError
from taskspace.trajopt import Spline, cubic_spline, quintic_spline

Q = np.array([0.0, 1.0, 0.5, 2.0])
K = np.arange(4.0)

REFUSED: dict[str, Callable[[], Spline]] = {
    "cubic waypoints 1.7e308": lambda: cubic_spline([0.0, 1.7e308, -1.7e308]),
    "cubic knots 1e200": lambda: cubic_spline(Q, K * 1e200),
    "cubic knots 1e-150": lambda: cubic_spline(Q, K * 1e-150),
    "cubic knots 1e-300": lambda: cubic_spline(Q, K * 1e-300),
    "cubic knots +-1.7e308": lambda: cubic_spline(Q, [-1.7e308, 0.0, 1.0, 1.7e308]),
    "cubic clamped velocities 1.7e308": lambda: cubic_spline(
        [0.0, 1.0, 2.0], boundary="clamped", start_velocity=1.7e308, end_velocity=-1.7e308
    ),
    "quintic knots 1e100": lambda: quintic_spline(Q, K * 1e100),
    "quintic knots 1e-100": lambda: quintic_spline(Q, K * 1e-100),
    "quintic knots 1e-300": lambda: quintic_spline(Q, K * 1e-300),
    "quintic knots 1e200": lambda: quintic_spline(Q, K * 1e200),
    "quintic hermite 1.7e308": lambda: quintic_spline(
        [0.0, 1.0, 2.0], velocities=[0.0, 1e308, 0.0], accelerations=[0.0, -1.7e308, 1.7e308]
    ),
}


@pytest.mark.parametrize("name", list(REFUSED))
def test_refused_without_numpy_warnings(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning would escape instead of the error
        with pytest.raises(InvalidInputError, match=r"knot spacings.*rescale"):
            REFUSED[name]()


@pytest.mark.parametrize("v0", [1e4, 1e8, 1e10, 1e11, 1e12, 1e14])
def test_large_exact_splines_are_accepted(v0: float) -> None:
    t = np.linspace(0.0, 1.0, 9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cubic = cubic_spline([0.0, 1.0, 2.0], boundary="clamped", start_velocity=v0)
        quintic = quintic_spline([0.0, 1.0, 2.0], start_velocity=v0)
        base = quintic_spline([0.0, 1.0, 2.0])
        unit = quintic_spline([0.0, 0.0, 0.0], start_velocity=1.0)
    ref = CubicSpline([0.0, 0.5, 1.0], [0.0, 1.0, 2.0], bc_type=((1, v0), (1, 0.0)))(t)
    np.testing.assert_allclose(cubic.evaluate(t)[:, 0], ref, rtol=1e-9, atol=1e-12 * v0)
    expected = base.evaluate(t)[:, 0] + v0 * unit.evaluate(t)[:, 0]
    np.testing.assert_allclose(quintic.evaluate(t)[:, 0], expected, rtol=1e-9, atol=1e-12 * v0)
