"""DMP rollouts with a time step too large for their semi-implicit Euler steps (audit 31).

With the default gains (alpha_z = 25, beta_z = alpha_z / 4) the transformation system's
Euler steps diverge for ``dt / tau >= 4 (sqrt 2 - 1) / alpha_z = 0.0663``. A DiscreteDMP fitted
on a 1 s demonstration ending at (1, 1) and rolled out with ``dt = 0.1`` ended at
(-8788, -7092) with no warning; RhythmicDMP and OrientationDMP use the same steps. Now such a
``dt`` is an InvalidInputError giving the largest stable step. Below it the rollout still
reaches the goal and agrees with a fine-step rollout.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import DiscreteDMP, DMPOptions, OrientationDMP, RhythmicDMP

LIMIT = 4.0 * (np.sqrt(2.0) - 1.0) / 25.0  # largest stable dt / tau for alpha_z = 25


def _discrete() -> DiscreteDMP:
    t = np.linspace(0.0, 1.0, 101)
    return DiscreteDMP.fit(t, np.c_[np.sin(t * np.pi / 2), t**2])


@pytest.mark.parametrize("dt", [0.08, 0.1, 0.2, 0.5, 1.0])
def test_discrete_diverging_step_is_refused(dt: float) -> None:
    with pytest.raises(InvalidInputError, match="dt"):
        _discrete().rollout(dt)


def test_discrete_stable_step_still_reaches_the_goal() -> None:
    dmp = _discrete()
    coarse = dmp.rollout(0.02, duration=3.0)
    fine = dmp.rollout(0.0005, duration=3.0)
    np.testing.assert_allclose(coarse.y[-1], [1.0, 1.0], atol=1e-3)
    np.testing.assert_allclose(coarse.y, fine.y[::40], atol=0.1)
    assert np.all(np.isfinite(dmp.rollout(0.065, duration=3.0).y))
    with pytest.raises(InvalidInputError, match="dt"):
        dmp.rollout(0.01, tau=0.01 / LIMIT)  # the bound scales with tau
    dmp.rollout(0.01, tau=0.0101 / LIMIT)


def test_gains_enter_the_bound() -> None:
    t = np.linspace(0.0, 1.0, 101)
    dmp = DiscreteDMP.fit(t, np.c_[t], DMPOptions(alpha_z=100.0))
    with pytest.raises(InvalidInputError, match="dt"):
        dmp.rollout(0.02)  # stable for alpha_z = 25, not for 100 (limit 0.0166 s)


def test_rhythmic_diverging_step_is_refused() -> None:
    t = np.linspace(0.0, 2.0, 201)
    dmp = RhythmicDMP.fit(t, np.c_[np.sin(2 * np.pi * t)])
    tau = dmp.tau
    y = dmp.rollout(0.5 * LIMIT * tau, duration=2.0).y
    assert np.all(np.abs(y) < 2.0)
    with pytest.raises(InvalidInputError, match="dt"):
        dmp.rollout(1.2 * LIMIT * tau, duration=2.0)


def test_orientation_diverging_step_is_refused() -> None:
    t = np.linspace(0.0, 1.0, 51)
    rotations = [pin.exp3(np.array([0.0, 0.0, 1.0]) * s) for s in t]
    dmp = OrientationDMP.fit(t, rotations)
    dmp.rollout(0.01)
    with pytest.raises(InvalidInputError, match="dt"):
        dmp.rollout(0.1)
