"""ZMP MPC given odd settings (audit of session 30): named errors, no silent reshape."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import (
    CartTable,
    ZmpMpc,
    ZmpMpcOptions,
)


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
