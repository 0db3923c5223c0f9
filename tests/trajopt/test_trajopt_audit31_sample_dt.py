"""TimeParametrizationResult.sample names a dt that is not a number (audit 31).

sample([0.1]) and sample("0.1") were bare TypeErrors ("'>' not supported between instances
of 'list' and 'float'") from inside the method.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.trajopt import time_parametrize

WAYPOINTS = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]])


def test_a_dt_that_is_not_a_number_is_named():
    result = time_parametrize(WAYPOINTS, 1.0, 1.0)
    for bad in ("0.1", None, [0.1, 0.2], 0.1j):
        with pytest.raises(InvalidInputError, match="dt"):
            result.sample(bad)
    for bad in (0.0, -0.1, float("nan"), float("inf")):
        with pytest.raises(InvalidInputError, match="dt"):
            result.sample(bad)


def test_numeric_dts_still_sample_to_the_end():
    result = time_parametrize(WAYPOINTS, 1.0, 1.0)
    a = result.sample(0.25)
    b = result.sample(np.float32(0.25))
    assert a.time[-1] == pytest.approx(result.duration)
    np.testing.assert_allclose(a.time, b.time)
    np.testing.assert_allclose(a.q[-1], WAYPOINTS[-1], atol=1e-9)
