"""The compiled inverse-dynamics step never certifies a NaN torque (a state beyond ~1e150).

Before: ur5 at v = 1e160 rad/s came back SOLVED from the compiled kernel with tau NaN (its
squares overflow, and NaN residuals passed its certificate); the Python path refuses that
QP (entries beyond 1e30). Now the compiled answer is checked (x, tau and the residuals
finite) and the Python path answers: both refuse. A large but finite state still gets a
finite torque from the kernel, equal to Pinocchio's RNEA of the returned acceleration.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import idqp_kernel
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.tasks import Task

pytestmark = pytest.mark.skipif(idqp_kernel() is None, reason="compiled IDQP kernel not built")


@pytest.fixture(scope="module")
def ur5() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("ur5", geometry=False)


def _controller(robot: Robot, native: bool) -> InverseDynamicsQP:
    posture = Task(F.JointConfiguration(robot), robot.q_default, kp=10.0)
    return InverseDynamicsQP(robot, [posture], options=InverseDynamicsOptions(native=native))


@pytest.mark.filterwarnings("error::RuntimeWarning")  # refused without a bare numpy warning
@pytest.mark.parametrize("speed", [1e160, 1e300])
def test_overflowing_state_is_refused_on_both_paths(ur5: Robot, speed: float) -> None:
    state = ur5.state(ur5.q_default, np.full(ur5.nv, speed))
    for native in (True, False):
        with pytest.raises(InvalidInputError, match="beyond 1e"):
            _controller(ur5, native).solve(state)


def test_fast_but_finite_state_is_answered_by_the_kernel(ur5: Robot) -> None:
    v = np.full(ur5.nv, 3.0)
    state = ur5.state(ur5.q_default, v)
    res = _controller(ur5, True).solve(state)
    assert res.success and res.compiled
    model = ur5._model
    tau = pin.rnea(model, model.createData(), ur5.q_default, v, res.a)
    np.testing.assert_allclose(res.tau, tau, rtol=1e-9, atol=1e-9)
