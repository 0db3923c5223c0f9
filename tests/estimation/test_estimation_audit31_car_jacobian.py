"""KinematicCarModel.jacobians agree with its mean beyond the steering limit (audit 31).

mean() clips the steering to max_steering; jacobians() did not: at delta = 0.9 rad (limit
0.6) df/du was off by 0.21 (tan(0.9) instead of tan(0.6) for the speed, and a nonzero
steering column although the clipped heading does not depend on delta), so an EKF's
process noise V M V^T was wrong whenever the command saturated.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.estimation import KinematicCarModel


def _finite_differences(model, x, u, h=1e-6):
    F, V = np.zeros((3, 3)), np.zeros((3, 2))
    for cols, arg, n in ((F, "x", 3), (V, "u", 2)):
        for i in range(n):
            e = np.zeros(n)
            e[i] = h
            if arg == "x":
                d = model.mean(x + e, u) - model.mean(x - e, u)
            else:
                d = model.mean(x, u + e) - model.mean(x, u - e)
            d[2] = (d[2] + np.pi) % (2 * np.pi) - np.pi
            cols[:, i] = d / (2 * h)
    return F, V


@pytest.mark.parametrize("steering", [0.3, -0.45, 0.9, -1.2, 3.0])
def test_jacobians_match_finite_differences_of_the_mean(steering):
    model = KinematicCarModel()
    x = np.array([0.3, -0.2, 0.7])
    u = np.array([2.0, steering])
    F, V = model.jacobians(x, u)
    F_ref, V_ref = _finite_differences(model, x, u)
    np.testing.assert_allclose(F, F_ref, atol=1e-7)
    np.testing.assert_allclose(V, V_ref, atol=1e-7)
