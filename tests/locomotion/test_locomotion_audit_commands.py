"""Commands and initial states that are not finite (audit of session 30): named errors."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import (
    CartTable,
    HopperParameters,
    PreviewController,
    RaibertOptions,
    simulate_hopper,
)


def test_hopper_names_a_speed_command_that_returns_nan():
    params, options = HopperParameters(), RaibertOptions()
    ok = simulate_hopper(params, options, lambda t: 0.5, 0.5)
    assert np.isfinite(ok.desired_speeds).all()
    for bad in (lambda t: float("nan"), lambda t: None, lambda t: [0.1, 0.2]):
        with pytest.raises(InvalidInputError, match=r"desired_speed\(t\)"):
            simulate_hopper(params, options, bad, 0.5)
    # a command that fails later, at a later apex, is named with its time
    with pytest.raises(InvalidInputError, match=r"at t = "):
        simulate_hopper(params, options, lambda t: 0.5 if t < 0.3 else np.inf, 2.0)


def test_preview_simulation_refuses_a_nan_initial_state():
    controller = PreviewController(CartTable())
    reference = np.zeros((20, 2))
    assert np.isfinite(controller.simulate(reference, np.zeros((3, 2))).com).all()
    start = np.zeros((3, 2))
    start[1, 0] = np.nan
    with pytest.raises(InvalidInputError, match="initial_state"):
        controller.simulate(reference, start)
