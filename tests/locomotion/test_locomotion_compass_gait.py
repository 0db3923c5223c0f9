"""Compass gait: swing dynamics, impact map, limit cycle (references: energy and angular
momentum computed from the point masses' positions alone, Carnot's theorem for plastic
impacts, the fixed point of Tedrake's notes / Drake's compass gait)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, SolverError
from taskspace.locomotion.compass_gait import (
    CompassGait,
    LimitCycleOptions,
    find_limit_cycle,
    return_map,
    simulate_step,
)

MASSES = ("stance_mass", "hip", "swing_mass")


@pytest.fixture(scope="module")
def walker():
    return CompassGait()


@pytest.fixture(scope="module")
def cycle(walker):
    return find_limit_cycle(walker, [-0.2, 1.0, -0.4])


def _velocities(walker, x, eps=1e-6):
    """Point-mass velocities by central differences of the positions along qd."""
    q, qd = x[:2], x[2:]
    plus, minus = walker.positions(q + eps * qd), walker.positions(q - eps * qd)
    return {n: (plus[n] - minus[n]) / (2 * eps) for n in plus}


def _mass(walker, name):
    return walker.hip_mass if name == "hip" else walker.leg_mass


def _energy(walker, x):
    p, v = walker.positions(x[:2]), _velocities(walker, x)
    return sum(_mass(walker, n) * (0.5 * v[n] @ v[n] + walker.gravity * p[n][1]) for n in MASSES)


def test_fixed_point_satisfies_return_map(walker, cycle):
    assert cycle.success
    z = cycle.fixed_point
    assert np.abs(return_map(walker, z) - z).max() < 1e-10
    # Tedrake's notes / Drake's compass gait: (theta_st, theta_sw, dtheta_st, dtheta_sw)
    # = (-0.2188, -0.3238, 1.0929, -0.3761) after impact (their angle conventions mapped)
    assert cycle.post_impact == pytest.approx([-0.2188, -0.3238, 1.0929, -0.3761], abs=2e-4)
    assert cycle.stable
    assert np.abs(cycle.floquet_multipliers).max() < 0.7
    # the return map's Jacobian predicts the growth of a small perturbation
    dz = 1e-5 * np.array([1.0, -2.0, 0.5])
    assert return_map(walker, cycle.fixed_point + dz) - z == pytest.approx(
        cycle.jacobian @ dz, abs=1e-7
    )


def test_perturbed_gait_returns_to_cycle(walker, cycle):
    z = cycle.fixed_point + np.array([0.01, -0.05, 0.03])
    for _ in range(12):
        z = return_map(walker, z)
    assert np.abs(z - cycle.fixed_point).max() < 1e-3


def test_energy_conserved_during_swing(walker, cycle):
    step = simulate_step(walker, cycle.post_impact, samples=50)
    assert step.success and step.duration == pytest.approx(cycle.period)
    energies = np.array([_energy(walker, x) for x in step.states])
    assert np.ptp(energies) < 1e-7 * abs(energies).max()
    assert walker.energy(step.states[7]) == pytest.approx(energies[7], rel=1e-9)


def test_impact_conserves_angular_momenta_and_loses_carnot_energy(walker, cycle):
    step = simulate_step(walker, cycle.post_impact)
    pre, post = step.pre_impact, step.post_impact
    p_pre, v_pre = walker.positions(pre[:2]), _velocities(walker, pre)
    p_post, v_post = walker.positions(post[:2]), _velocities(walker, post)
    shift = p_pre["swing_foot"]  # the new frame's origin in the old frame
    # the same bodies before and after: the legs swap roles
    same = {"stance_mass": "swing_mass", "hip": "hip", "swing_mass": "stance_mass"}

    def cross(r, v):
        return r[0] * v[1] - r[1] * v[0]

    L_pre = sum(_mass(walker, n) * cross(p_pre[n] - shift, v_pre[n]) for n in MASSES)
    L_post = sum(_mass(walker, n) * cross(p_post[n], v_post[n]) for n in MASSES)
    assert L_post == pytest.approx(L_pre, rel=1e-8)
    # trailing leg about the hip
    lp = walker.leg_mass * cross(p_pre["stance_mass"] - p_pre["hip"], v_pre["stance_mass"])
    lq = walker.leg_mass * cross(p_post["swing_mass"] - p_post["hip"], v_post["swing_mass"])
    assert lq == pytest.approx(lp, rel=1e-8)
    # positions are unchanged by the impact
    for n in MASSES:
        assert p_post[same[n]] == pytest.approx(p_pre[n] - shift, abs=1e-12)
    # Carnot: kinetic energy lost = kinetic energy of the velocity jumps
    ke_pre = sum(0.5 * _mass(walker, n) * v_pre[n] @ v_pre[n] for n in MASSES)
    ke_post = sum(0.5 * _mass(walker, n) * v_post[n] @ v_post[n] for n in MASSES)
    jump = sum(0.5 * _mass(walker, n) * np.sum((v_pre[n] - v_post[same[n]]) ** 2) for n in MASSES)
    assert ke_pre - ke_post == pytest.approx(jump, rel=1e-7)
    assert jump > 0.01 * ke_pre
    # over a period the impact loss equals the potential energy of one step down the slope
    drop = -shift[1]
    total = walker.hip_mass + 2 * walker.leg_mass
    assert ke_pre - ke_post == pytest.approx(total * walker.gravity * drop, rel=1e-8)


def test_falls_and_errors(walker):
    with pytest.raises(SolverError, match="return map undefined"):
        return_map(walker, [-0.2, 0.2, -1.0])
    with pytest.raises(InvalidInputError, match="0 < a < leg_length"):
        CompassGait(a=1.5)
    bad = find_limit_cycle(walker, [-0.2, 1.0, -0.4], LimitCycleOptions(max_iterations=1))
    assert not bad.success and bad.residual > 1e-6
