"""Robot.check_configuration / check_velocity on huge finite values: no overflow warning.

Their fast path tested finiteness with ``x.dot(x)``, which overflows for |x| > 1e154 and
emitted a bare numpy RuntimeWarning ("overflow encountered in dot") on a valid input, e.g.
``Viewer.display`` of a configuration with 1e300 rad.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace.errors import NotFiniteError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda")


@pytest.mark.parametrize("value", [1e155, 1e300, -1.7e308, 5e-324])
def test_huge_finite_values_pass_without_warning(panda: Robot, value: float) -> None:
    q = np.full(panda.nq, value)
    v = np.full(panda.nv, value)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(panda.check_configuration(q), q)
        np.testing.assert_array_equal(panda.check_velocity(v), v)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("index", [0, 3, 6])
def test_non_finite_values_still_refused(panda: Robot, bad: float, index: int) -> None:
    """Refused with the index named, and no numpy warning on the way (0 * inf would give one)."""
    q = np.full(panda.nq, 1e300)
    q[index] = bad
    v = np.zeros(panda.nv)
    v[index] = bad
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NotFiniteError, match=rf"indices \[{index}\]"):
            panda.check_configuration(q)
        with pytest.raises(NotFiniteError, match=rf"indices \[{index}\]"):
            panda.check_velocity(v)
