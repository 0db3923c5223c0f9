"""ZMP MPC given odd settings (audit of session 30): named errors, no silent reshape."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, SolverError
from taskspace.locomotion import (
    CartTable,
    SoleSize,
    ZmpMpc,
    ZmpMpcOptions,
    mpc_walking_pattern,
    straight_walk,
)
from taskspace.locomotion.zmp_mpc import _inradius
from taskspace.locomotion.zmp_reference import support_polygons


def test_initial_state_must_be_three_rows_per_axis():
    mpc = ZmpMpc(CartTable(dt=0.05), ZmpMpcOptions(constrain_zmp=False))
    reference = np.tile([0.1, -0.05], (10, 1))
    rest = np.array([[0.1, -0.05], [0.0, 0.0], [0.0, 0.0]])
    default = mpc.simulate(reference).trajectory.com
    assert np.allclose(mpc.simulate(reference, initial_state=rest).trajectory.com, default)
    # (2, 3) (one row per axis) and (6,) were reshaped to (3, 2) silently: another state
    for bad in (rest.T, rest.ravel(), rest.T.ravel()):
        with pytest.raises(InvalidInputError, match="initial_state"):
            mpc.simulate(reference, initial_state=bad)
    start = rest.copy()
    start[2, 1] = np.nan
    with pytest.raises(InvalidInputError, match="initial_state"):
        mpc.simulate(reference, initial_state=start)


def test_a_margin_wider_than_the_soles_is_named():
    plan = straight_walk(3)
    sole = SoleSize(length=0.2, width=0.1)
    # a 0.2 m x 0.1 m sole holds a disk of radius 0.05 m (by hand), two soles a larger one
    polys = support_polygons(plan, np.linspace(0.0, plan.duration, 50), sole)
    assert min(_inradius(p) for p in polys) == pytest.approx(0.05, abs=1e-9)
    _, result = mpc_walking_pattern(plan, options=ZmpMpcOptions(zmp_margin=0.04), sole=sole)
    assert result.trajectory.com.shape[1] == 2
    with pytest.raises(SolverError, match=r"exceeds the inradius 0\.05 m"):
        mpc_walking_pattern(plan, options=ZmpMpcOptions(zmp_margin=0.06), sole=sole)
