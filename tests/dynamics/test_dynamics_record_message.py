"""simulate's record-size error reads as a number (audit6: dt=1e-300 printed 301 digits)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.dynamics import simulate
from taskspace.errors import InvalidInputError
from taskspace.model import Robot


def test_huge_sample_counts_are_short(robot_loader) -> None:  # type: ignore[no-untyped-def]
    ur5: Robot = robot_loader("ur5")
    x0 = (ur5.q_default, np.zeros(ur5.nv))
    with pytest.raises(InvalidInputError, match=r"would record 1e\+300 samples") as err:
        simulate(ur5, None, x0, 1.0, 1e-300)
    assert len(str(err.value)) < 400
    with pytest.raises(InvalidInputError, match=r"would record 1,000,000,000,001 samples"):
        simulate(ur5, None, x0, 1.0, 1e-12)
