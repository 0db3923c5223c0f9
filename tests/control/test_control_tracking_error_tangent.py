"""tracking_error measures the tangent-space error (Pinocchio's difference), not raw q entries.

Kinova has continuous joints (``(cos, sin)`` per joint, ``nq > nv``). Each configuration is the
reference moved by a known tangent step ``dv`` (``pin.integrate``), so the exact error is
``max|dv|`` [rad]; the old code compared ``cos``/``sin`` entries (about ``0.5`` for a 1 rad step
on one continuous joint, not 1 rad) and had no ``robot`` argument.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import ConstantReference, tracking_error
from taskspace.errors import InvalidInputError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def kinova() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("kinova", geometry=False)


def test_tracking_error_is_the_tangent_error_on_continuous_joints(kinova: Robot) -> None:
    model = kinova.model
    q_ref = kinova.q_default
    ref = ConstantReference(q_ref, velocity_size=kinova.nv)
    rng = np.random.default_rng(3)
    steps = [rng.uniform(-1.0, 1.0, kinova.nv) for _ in range(4)]
    steps.append(np.zeros(kinova.nv))
    qs = np.array([pin.integrate(model, q_ref, dv) for dv in steps])
    err = tracking_error(np.arange(len(steps)) * 0.1, qs, ref, robot=kinova)
    np.testing.assert_allclose(err, [np.max(np.abs(dv)) for dv in steps], atol=1e-12)


def test_tracking_error_refuses_non_vector_configurations_without_robot(kinova: Robot) -> None:
    ref = ConstantReference(kinova.q_default, velocity_size=kinova.nv)
    qs = np.array([kinova.q_default])
    with pytest.raises(InvalidInputError, match="robot="):
        tracking_error([0.0], qs, ref)
