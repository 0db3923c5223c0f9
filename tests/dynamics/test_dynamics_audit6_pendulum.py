"""The pendulum's closed forms given arrays of different shapes, new-user sweep audit6.

Before: ``pendulum_torque(np.zeros(3), np.zeros(2))`` (and the acceleration and energy) raised
numpy's bare "operands could not be broadcast" ValueError. Broadcastable shapes keep numpy's
broadcasting, checked against the slide 5:22 formula evaluated element by element.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.dynamics import pendulum_acceleration, pendulum_energy, pendulum_torque
from taskspace.errors import InvalidInputError


@pytest.mark.parametrize("f", [pendulum_torque, pendulum_acceleration, pendulum_energy])
def test_shapes_that_do_not_broadcast_are_named(f) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match=r"shapes \(3,\) and \(2,\)"):
        f(np.zeros(3), np.zeros(2))


def test_broadcastable_shapes_follow_the_formula() -> None:
    theta = np.array([[0.0], [0.5], [-2.0]])  # (3, 1)
    acc = np.array([1.0, -3.0])  # (2,)
    out = pendulum_torque(theta, acc, mass=2.0, length=0.5, inertia=0.1)
    assert out.shape == (3, 2)
    for i in range(3):
        for j in range(2):
            u = (2.0 * 0.25 + 0.1) * acc[j] + 2.0 * 9.81 * 0.5 * np.sin(theta[i, 0])
            assert out[i, j] == pytest.approx(u, rel=1e-15)
