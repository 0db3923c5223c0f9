from __future__ import annotations

import numpy as np
import pytest

from taskspace.control import (
    ComputedTorqueController,
    JointPDController,
    SampledReference,
    SinusoidalReference,
    pd_response,
    tracking_error,
)
from taskspace.dynamics import SimulationOptions, simulate
from taskspace.errors import InvalidInputError

# joint impedance gains of Franka's own examples [N m/rad], [N m s/rad]
KP = [600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0]
KD = [50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0]


@pytest.fixture(scope="module")
def reference(panda):  # type: ignore[no-untyped-def]
    return SinusoidalReference(panda.q_default, 0.3, [0.5, 0.4, 0.3, 0.5, 0.6, 0.4, 0.5])


def test_computed_torque_error_is_a_point_mass(panda) -> None:  # type: ignore[no-untyped-def]
    # slide 5:30: with an exact model every joint error obeys e'' + Kd e' + Kp e = 0
    ref = SinusoidalReference(panda.q_default, 0.2, 0.5)
    kp, kd = 25.0, 6.0
    ctrl = ComputedTorqueController(panda, ref, kp, kd)
    e0 = np.array([0.1, -0.05, 0.08, 0.02, -0.1, 0.05, 0.03])
    r0 = ref(0.0)
    traj = simulate(
        panda, ctrl, (r0.q - e0, r0.v), 1.5, 1e-3, SimulationOptions(hold_control=False)
    )
    errors = np.array([ref(t).q for t in traj.t]) - traj.q
    for j in range(7):
        expected = pd_response(traj.t, mass=1.0, kp=kp, kd=kd, q0=e0[j]).q
        np.testing.assert_allclose(errors[:, j], expected, atol=1e-6)


def test_computed_torque_beats_naive_pd(panda, reference) -> None:  # type: ignore[no-untyped-def]
    r0 = reference(0.0)
    x0 = (r0.q, r0.v)
    ct = simulate(
        panda, ComputedTorqueController.from_wavelength(panda, reference, 0.05), x0, 2.0, 1e-3
    )
    pd = simulate(panda, JointPDController(panda, reference, KP, KD), x0, 2.0, 1e-3)
    e_ct = tracking_error(ct.t, ct.q, reference)
    e_pd = tracking_error(pd.t, pd.q, reference)
    # stated bound: computed torque (lambda = 50 ms) with a 1 ms zero-order hold tracks
    # within 5e-4 rad (measured 1.2e-4 rad); naive PD with gravity compensation: 5.9e-3 rad
    assert e_ct.max() < 5e-4
    assert e_pd.max() > 10 * e_ct.max()


def test_gravity_compensation_removes_pd_offset(panda) -> None:  # type: ignore[no-untyped-def]
    q_star = panda.q_default
    x0 = (q_star, np.zeros(7))
    with_g = simulate(panda, JointPDController(panda, q_star, KP, KD), x0, 1.0, 1e-3)
    without = simulate(
        panda, JointPDController(panda, q_star, KP, KD, gravity_compensation=False), x0, 1.0, 1e-3
    )
    assert np.max(np.abs(with_g.q[-1] - q_star)) < 1e-9
    assert np.max(np.abs(without.q[-1] - q_star)) > 1e-3


def test_sampled_reference_finite_differences() -> None:
    tau = 0.01
    t = np.arange(0, 1.0 + tau / 2, tau)
    samples = np.stack([t**2, np.sin(t)], axis=1)
    ref = SampledReference(samples, tau)
    point = ref(0.5)
    np.testing.assert_allclose(point.q, [0.25, np.sin(0.5)], atol=1e-12)
    np.testing.assert_allclose(point.v, [1.0, np.cos(0.5)], atol=1e-4)
    np.testing.assert_allclose(point.a, [2.0, -np.sin(0.5)], atol=1e-4)
    assert np.all(ref(5.0).v == 0)


def test_error_paths(panda, talos) -> None:  # type: ignore[no-untyped-def]
    msg = r"needs a fixed-base robot.*'talos' has a floating"
    with pytest.raises(InvalidInputError, match=msg):
        ComputedTorqueController(talos, talos.q_default)
    with pytest.raises(InvalidInputError, match=r"kp \[1/s\^2\] must be finite and >= 0"):
        ComputedTorqueController(panda, panda.q_default, kp=-1.0)
    with pytest.raises(InvalidInputError, match="reference must be callable"):
        ComputedTorqueController(panda, np.zeros(3))
    with pytest.raises(InvalidInputError, match=r"wavelength \[s\] must be finite and > 0"):
        ComputedTorqueController.from_wavelength(panda, panda.q_default, 0.0)
    with pytest.raises(InvalidInputError, match="samples needs at least 3 rows"):
        SampledReference(np.zeros((2, 3)), 0.1)
