"""Robot inputs of the new-user sweep that gave NaN configurations or bare Python errors.

* ``integrate(q, v, dt)`` with ``dt`` NaN or inf returned a NaN/inf configuration, ``dt="1"``
  raised numpy's UFuncTypeError, and ``v * dt`` overflowing returned inf entries.
* ``random_configuration(None)`` (or a seed) raised ``AttributeError: ... 'uniform'``; a NaN
  ``base_box`` gave NaN base positions.
* ``Robot.load(..., locked_values={joint: nan})`` built the robot with the locked joint's
  links at NaN.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace import InvalidInputError, NotFiniteError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def panda() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("panda", geometry=False)


@pytest.fixture(scope="module")
def solo() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("solo12", geometry=False)


@pytest.mark.parametrize("dt", [float("nan"), float("inf"), -float("inf"), "1", None])
def test_integrate_refuses_a_dt_that_is_not_a_finite_number(panda: Robot, dt: object) -> None:
    with pytest.raises(InvalidInputError, match="dt must be a"):
        panda.integrate(panda.q_default, np.ones(panda.nv), dt)  # type: ignore[arg-type]


def test_integrate_overflow_is_an_error_and_finite_steps_match_pinocchio(solo: Robot) -> None:
    q = solo.q_default
    with pytest.raises(NotFiniteError, match="v \\* dt overflows"):
        solo.integrate(q, np.full(solo.nv, 1e308), 10.0)
    v = np.linspace(-1.0, 1.0, solo.nv)
    for dt in (0.0, 0.01, np.float32(0.5), 2, -0.3):
        expected = pin.integrate(solo.model, q, v * float(dt))
        np.testing.assert_allclose(solo.integrate(q, v, dt), expected, atol=1e-15)  # type: ignore[arg-type]


@pytest.mark.parametrize("rng", [None, 3, np.random.RandomState(0)])
def test_random_configuration_needs_a_generator(panda: Robot, rng: object) -> None:
    with pytest.raises(
        InvalidInputError, match=r"rng must be a numpy Generator \(np.random.default_rng"
    ):
        panda.random_configuration(rng)  # type: ignore[arg-type]


@pytest.mark.parametrize("box", [float("nan"), 0.0, -1.0, float("inf")])
def test_random_configuration_base_box(solo: Robot, box: float) -> None:
    with pytest.raises(InvalidInputError, match="base_box must be finite and > 0"):
        solo.random_configuration(np.random.default_rng(0), base_box=box)
    q = solo.random_configuration(np.random.default_rng(0), base_box=0.25)
    assert np.all(np.abs(q[:3]) <= 0.25)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), "0.01", None])
def test_locked_values_must_be_finite_numbers(value: object) -> None:
    with pytest.raises(
        InvalidInputError, match=r"locked_values\['panda_finger_joint1'\] must be a"
    ):
        Robot.load("panda", geometry=False, locked_values={"panda_finger_joint1": value})  # type: ignore[dict-item]
