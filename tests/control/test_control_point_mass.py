from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from taskspace.control import (
    DampingRegime,
    PIDController,
    PIDGains,
    critically_damped_response,
    damping_regime,
    overdamped_response,
    pd_response,
    underdamped_response,
)
from taskspace.errors import InvalidInputError


@pytest.mark.parametrize(
    ("kp", "kd", "regime", "fn"),
    [
        (3.0, 5.0, DampingRegime.OVERDAMPED, overdamped_response),
        (4.0, 4.0, DampingRegime.CRITICALLY_DAMPED, critically_damped_response),
        (9.0, 1.0, DampingRegime.UNDERDAMPED, underdamped_response),
        (9.0, 0.0, DampingRegime.UNDAMPED, underdamped_response),
    ],
)
def test_closed_forms_solve_the_ode(kp, kd, regime, fn) -> None:  # type: ignore[no-untyped-def]
    m, q0, v0, target = 1.0, 0.7, -0.4, 0.2
    t = np.linspace(0, 4, 81)
    resp = fn(t, mass=m, kp=kp, kd=kd, q0=q0, v0=v0, target=target)
    assert resp.regime is regime
    sol = solve_ivp(
        lambda _t, x: [x[1], (kp * (target - x[0]) - kd * x[1]) / m],
        (0, 4),
        [q0, v0],
        t_eval=t,
        rtol=1e-12,
        atol=1e-12,
    )
    np.testing.assert_allclose(resp.q, sol.y[0], atol=1e-8)
    np.testing.assert_allclose(resp.v, sol.y[1], atol=1e-8)
    np.testing.assert_allclose(
        pd_response(t, mass=m, kp=kp, kd=kd, q0=q0, v0=v0, target=target).q, resp.q
    )


def test_undamped_oscillation_frequency() -> None:
    # slide 5:8: q(t) = q* + b cos(sqrt(Kp/m) t)
    t = np.linspace(0, 10, 200)
    resp = underdamped_response(t, mass=2.0, kp=8.0, kd=0.0, q0=1.0)
    np.testing.assert_allclose(resp.q, np.cos(2.0 * t), atol=1e-12)


def test_wavelength_gains_slide_5_14() -> None:
    gains = PIDGains.from_wavelength(mass=2.0, wavelength=0.5, damping_ratio=0.3)
    assert gains.kp == pytest.approx(2.0 / 0.25)
    assert gains.kd == pytest.approx(2 * 2.0 * 0.3 / 0.5)
    assert gains.wavelength(2.0) == pytest.approx(0.5)
    assert gains.damping_ratio(2.0) == pytest.approx(0.3)
    # q(t) = q* + b exp(-xi t / lambda) exp(i sqrt(1 - xi^2) t / lambda)
    resp = pd_response(0.0, mass=2.0, kp=gains.kp, kd=gains.kd, q0=1.0)
    w = resp.exponents[0]
    assert w.real == pytest.approx(-0.3 / 0.5)
    assert abs(w.imag) == pytest.approx(np.sqrt(1 - 0.09) / 0.5)
    assert damping_regime(1.0, 25.0, 10.0) is DampingRegime.CRITICALLY_DAMPED


def test_error_paths() -> None:
    with pytest.raises(InvalidInputError, match="needs overdamped; use pd_response"):
        overdamped_response(1.0, mass=1.0, kp=4.0, kd=1.0, q0=1.0)
    with pytest.raises(InvalidInputError, match=r"kp \[N/m\] must be finite and > 0"):
        pd_response(1.0, mass=1.0, kp=0.0, kd=1.0, q0=1.0)
    with pytest.raises(InvalidInputError, match=r"mass \[kg\] must be finite and > 0"):
        pd_response(1.0, mass=-1.0, kp=1.0, kd=1.0, q0=1.0)
    with pytest.raises(InvalidInputError, match=r"wavelength \[s\] must be finite and > 0"):
        PIDGains.from_wavelength(1.0, 0.0, 1.0)
    with pytest.raises(InvalidInputError, match="kd must be finite and >= 0"):
        PIDGains(kp=1.0, kd=-1.0)
    with pytest.raises(InvalidInputError, match="q0 must be a finite"):
        pd_response(1.0, mass=1.0, kp=1.0, kd=1.0, q0=np.nan)
    pid = PIDController(PIDGains(kp=1.0, ki=1.0), 0.0)
    pid(1.0, 0.0, 0.0)
    with pytest.raises(InvalidInputError, match="PID time went backwards"):
        pid(0.5, 0.0, 0.0)
