"""Raibert hopper: stance mechanics (energy without losses, angular momentum about the foot
changed by gravity alone), hopping in place, speed tracking 0.1-2 m/s, attitude servo."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from taskspace.errors import InvalidInputError
from taskspace.locomotion.raibert_hopper import (
    HopperParameters,
    RaibertOptions,
    simulate_hopper,
    stance_dynamics,
    stance_energy,
)

SPEED_BOUND = 0.04
"""Steady-state speed error bound [m/s] over the last five hops of a 20 s run."""


def _stance(params, s0, foot, rest, torque, t_end=0.08):
    return solve_ivp(
        lambda _t, s: stance_dynamics(params, s, foot, rest, torque)[0],
        (0, t_end),
        s0,
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
        dense_output=True,
    )


def test_lossless_stance_conserves_energy():
    params = HopperParameters(leg_damping=0.0)
    s0 = np.array([-0.05, 0.49, 0.1, 0.8, -1.5, 0.3])
    sol = _stance(params, s0, foot=0.0, rest=0.5, torque=0.0)
    energies = [stance_energy(params, s, 0.0, 0.5) for s in sol.y.T]
    assert np.ptp(energies) < 1e-9 * abs(energies[0])
    # with damping the energy decreases
    lossy = HopperParameters(leg_damping=50.0)
    sol = _stance(lossy, s0, 0.0, 0.5, 0.0)
    assert stance_energy(lossy, sol.y[:, -1], 0.0, 0.5) < energies[0] - 1e-3


def test_hip_torque_leaves_angular_momentum_about_foot_to_gravity():
    params = HopperParameters()
    M, g, foot = params.body_mass, params.gravity, 0.02
    s0 = np.array([-0.08, 0.48, 0.0, 1.0, -1.0, 0.0])
    sol = _stance(params, s0, foot, 0.5, torque=4.0, t_end=0.06)

    def momentum(s):
        return M * ((s[0] - foot) * s[4] - s[1] * s[3]) + params.body_inertia * s[5]

    gravity_impulse = quad(lambda t: -M * g * (sol.sol(t)[0] - foot), 0, 0.06, epsabs=1e-12)[0]
    assert momentum(sol.y[:, -1]) - momentum(s0) == pytest.approx(gravity_impulse, abs=1e-9)
    assert sol.y[5, -1] == pytest.approx(-4.0 / params.body_inertia * 0.06, rel=1e-12)


def test_hops_in_place_at_the_desired_height():
    res = simulate_hopper(HopperParameters(), RaibertOptions(hop_height=0.7), 0.0, 15.0)
    assert res.success, res.message
    assert len(res.apex_heights) > 20
    assert np.abs(res.apex_heights[-5:] - 0.7).max() < 0.02
    assert np.abs(res.states[:, 0]).max() < 1e-9  # no drift
    assert np.all(res.thrusts[-5:] > 0)  # thrust makes up for the damping


@pytest.mark.parametrize("speed", [0.1, 1.0, 2.0])
def test_tracks_forward_speed(speed):
    res = simulate_hopper(
        HopperParameters(),
        RaibertOptions(),
        lambda t: min(speed, 0.25 * t),  # ramped command
        20.0,
        initial_state=[0.0, 0.7, 0.2, 0.0, 0.0, 0.0],  # pitched body: the servo levels it
    )
    assert res.success, res.message
    err = res.apex_speeds[-5:] - speed
    assert np.abs(err).max() < SPEED_BOUND
    assert np.abs(res.states[-50:, 2]).max() < 1e-3
    assert np.all(res.states[res.in_stance, 1] > 0.3)


def test_raibert_law_without_integral_has_a_steady_error():
    res = simulate_hopper(HopperParameters(), RaibertOptions(speed_integral_gain=0.0), 0.5, 15.0)
    assert res.success
    assert 0.05 < np.mean(0.5 - res.apex_speeds[-5:]) < 0.2  # the known offset of the law


def test_must_start_in_flight():
    with pytest.raises(InvalidInputError, match="start in flight"):
        simulate_hopper(
            HopperParameters(), RaibertOptions(), 0.0, 1.0, initial_state=[0, 0.4, 0, 0, 0, 0]
        )
