"""Point-mass PD responses and gain helpers on bad or extreme inputs (#15, new-user sweep).

Before: pd_response(q0="x" / None / 1j, or t="x") raised bare ValueError / TypeError; the
overdamped root -sigma + root lost its digits for kd >> sqrt(m kp) (kd = 1e8: decay rate
-7.45e-9 instead of -1e-8, the response wrong by far more than rounding) and kd^2 overflowed
above 1e154 (NaN responses with warnings); gains_from_wavelength(1e300) raised a bare
OverflowError and (1e-300) a bare ZeroDivisionError; gaussian_propagation overflowed with
warnings. References: the closed form in 700-digit decimals; 1 / lambda^2 and 2 xi / lambda.
"""

from __future__ import annotations

import warnings
from decimal import Decimal, localcontext
from typing import Any

import numpy as np
import pytest

from taskspace.control import gains_from_wavelength, overdamped_response, pd_response
from taskspace.errors import InvalidInputError
from taskspace.estimation import gaussian_propagation


@pytest.mark.parametrize("value", ["x", None, 1j, [1.0, 2.0]])
@pytest.mark.parametrize("name", ["q0", "v0", "target"])
def test_response_scalars_are_checked(name: str, value: Any) -> None:
    kwargs: dict[str, Any] = {"mass": 1.0, "kp": 4.0, "kd": 4.0, "q0": 1.0, name: value}
    with pytest.raises(InvalidInputError, match=name):
        pd_response(np.linspace(0, 1, 3), **kwargs)


@pytest.mark.parametrize("t", ["x", 1j, ["a", "b"], None])
def test_response_times_are_checked(t: Any) -> None:
    with pytest.raises(InvalidInputError, match="t"):
        pd_response(t, mass=1.0, kp=4.0, kd=4.0, q0=1.0)


def _reference(t: float, mass: float, kp: float, kd: float, e0: float, v0: float) -> float:
    """e(t) of m e'' + kd e' + kp e = 0 (overdamped), in 700-digit decimals (kd^2 = 1e600
    must keep 4 m kp = 4e-3)."""
    with localcontext() as ctx:
        ctx.prec = 700
        m, p, d = Decimal(mass), Decimal(kp), Decimal(kd)
        root = (d * d - 4 * m * p).sqrt() / (2 * m)
        w1, w2 = -d / (2 * m) + root, -d / (2 * m) - root
        c1 = (Decimal(v0) - w2 * Decimal(e0)) / (w1 - w2)
        c2 = Decimal(e0) - c1
        return float(c1 * (w1 * Decimal(t)).exp() + c2 * (w2 * Decimal(t)).exp())


@pytest.mark.parametrize(
    ("mass", "kp", "kd"), [(1.0, 1.0, 1e8), (1.0, 1.0, 1e12), (2.0, 3.0, 10.0), (1.0, 1e-3, 1e300)]
)
def test_overdamped_response_matches_the_decimal_closed_form(
    mass: float, kp: float, kd: float
) -> None:
    slow = kd / kp  # time constant of the slow mode
    times = np.array([0.0, 0.1, 0.5, 1.0, 2.0]) * min(slow, 1e300)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for fn in (pd_response, overdamped_response):
            r = fn(times, mass=mass, kp=kp, kd=kd, q0=1.0, v0=0.0)
            ref = [_reference(float(t), mass, kp, kd, 1.0, 0.0) for t in times]
            np.testing.assert_allclose(r.q, ref, rtol=1e-12, atol=1e-300)
            assert np.isfinite(r.v).all()


@pytest.mark.parametrize("wavelength", [1e300, 1e-300, 1e200, 1e-200])
def test_gains_from_wavelength_out_of_range(wavelength: float) -> None:
    with pytest.raises(InvalidInputError, match="wavelength"):
        gains_from_wavelength(wavelength, 1.0)


@pytest.mark.parametrize("wavelength", [1e-100, 0.05, 1.0, 1e100])
def test_gains_from_wavelength_in_range(wavelength: float) -> None:
    kp, kd = gains_from_wavelength(wavelength, 0.7)
    assert kp == pytest.approx(wavelength**-2, rel=1e-15)
    assert kd == pytest.approx(1.4 / wavelength, rel=1e-15)


def test_gaussian_propagation_overflow_is_refused() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidInputError, match="overflows"):
            gaussian_propagation(np.zeros(2), np.eye(2), 1e200 * np.eye(2), np.zeros(2), np.eye(2))
