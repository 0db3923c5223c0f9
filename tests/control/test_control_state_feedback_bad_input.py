"""Bad inputs to the state-feedback controller (issue #15).

Reference: at the equilibrium the controller returns the equilibrium torques (gravity
compensation from Pinocchio) whatever the gain.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control.linearization import linearize
from taskspace.control.state_feedback import StateFeedbackController
from taskspace.errors import InvalidInputError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def ur5() -> Robot:
    return Robot.load("ur5")


def test_state_feedback_inputs(ur5: Robot) -> None:
    q = ur5.q_default
    ctrl = StateFeedbackController(ur5, linearize(ur5, q), np.ones((6, 12)))
    gravity = pin.computeGeneralizedGravity(ur5.model, ur5.model.createData(), q)
    np.testing.assert_allclose(ctrl(0.0, q, np.zeros(6)), gravity, atol=1e-9)
    with pytest.raises(InvalidInputError):  # bare Pinocchio ValueError
        ctrl(0.0, np.zeros(5), np.zeros(6))
    with pytest.raises(InvalidInputError):  # NaN torques
        ctrl(0.0, np.full(6, np.nan), np.zeros(6))
    with pytest.raises(InvalidInputError):  # NaN torques
        ctrl(0.0, q, np.full(6, np.nan))
    with pytest.raises(InvalidInputError):  # bare AttributeError
        StateFeedbackController(ur5, 5, np.zeros((6, 12)))  # type: ignore[arg-type]
