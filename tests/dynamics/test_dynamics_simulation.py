from __future__ import annotations

import example_robot_data as erd
import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import PIDController, PIDGains, pd_response, point_mass_robot
from taskspace.dynamics import (
    ForwardDynamics,
    JointFriction,
    SimulationOptions,
    SimulationStatus,
    forward_dynamics,
    kinetic_energy,
    potential_energy,
    simulate,
)
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def double_pendulum() -> Robot:
    rw = erd.load("double_pendulum")
    return Robot(rw.model, rw.collision_model, rw.visual_model, name="double_pendulum")


@pytest.mark.parametrize(
    ("kp", "kd"),
    [(4.0, 10.0), (4.0, 4.0), (4.0, 0.8), (9.0, 0.0)],
    ids=["overdamped", "critical", "underdamped", "undamped"],
)
def test_point_mass_pd_matches_closed_form(kp: float, kd: float) -> None:
    mass = 2.0
    kp, kd = kp * mass, kd * mass  # same regimes for m = 2
    robot = point_mass_robot(mass)
    pd = PIDController.pd(kp, kd, target=0.5)
    traj = simulate(
        robot,
        pd,
        (np.array([-0.3]), np.array([0.2])),
        5.0,
        1e-3,
        SimulationOptions(hold_control=False),  # the continuous-time law of slide 5:10
    )
    ref = pd_response(traj.t, mass=mass, kp=kp, kd=kd, q0=-0.3, v0=0.2, target=0.5)
    assert traj.success
    assert np.max(np.abs(traj.q[:, 0] - ref.q)) < 1e-6
    assert np.max(np.abs(traj.v[:, 0] - ref.v)) < 1e-6


def test_zero_order_hold_is_first_order_accurate() -> None:
    # held torques: the error vs the continuous law shrinks linearly with dt
    robot = point_mass_robot(1.0)
    errs = []
    for dt in (4e-3, 2e-3):
        traj = simulate(robot, PIDController.pd(4.0, 4.0, 1.0), (np.zeros(1), np.zeros(1)), 2.0, dt)
        ref = pd_response(traj.t, mass=1.0, kp=4.0, kd=4.0, q0=0.0, target=1.0)
        errs.append(np.max(np.abs(traj.q[:, 0] - ref.q)))
    assert 1.7 < errs[0] / errs[1] < 2.3


def test_energy_drift_double_pendulum(double_pendulum: Robot) -> None:
    x0 = (np.array([1.0, 0.5]), np.zeros(2))
    rk4 = simulate(double_pendulum, None, x0, 10.0, 1e-3, SimulationOptions(integrator="rk4"))
    sie = simulate(
        double_pendulum, None, x0, 10.0, 1e-3, SimulationOptions(integrator="semi_implicit_euler")
    )
    # gravity acts: the pendulum swings through most of its energy as kinetic energy
    assert np.ptp(rk4.kinetic_energy) > 0.5
    # stated bounds over 10 s at dt = 1 ms: RK4 < 1e-5 J (measured 1.0e-6 J),
    # semi-implicit Euler < 1 J (measured 0.39 J; it is not symplectic with Coriolis terms)
    assert rk4.energy_drift < 1e-5
    assert sie.energy_drift < 1.0
    assert sie.energy_drift > 1e4 * rk4.energy_drift


def test_energy_drift_panda(panda: Robot) -> None:
    x0 = (panda.q_default, np.zeros(7))
    rk4 = simulate(panda, None, x0, 10.0, 1e-3)
    sie = simulate(panda, None, x0, 10.0, 5e-4, SimulationOptions(integrator="semi_implicit_euler"))
    assert rk4.success and sie.success
    assert np.ptp(rk4.kinetic_energy) > 10.0  # the arm falls and whips around
    # stated bounds over 10 s: RK4 (dt = 1 ms) < 1e-3 J (measured 1.8e-5 J); semi-implicit
    # Euler (dt = 0.5 ms) < 100 J (measured 36 J; at dt = 1 ms it diverges)
    assert rk4.energy_drift < 1e-3
    assert sie.energy_drift < 100.0
    assert sie.energy_drift > 1e4 * rk4.energy_drift


def test_energies_match_definitions(panda: Robot, rng: np.random.Generator) -> None:
    q = panda.random_configuration(rng)
    v = rng.normal(size=7)
    data = panda.model.createData()
    M = pin.crba(panda.model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    assert kinetic_energy(panda, q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)
    pin.centerOfMass(panda.model, data, q)
    expected = -panda.mass * (panda.model.gravity.linear @ data.com[0])
    assert potential_energy(panda, q) == pytest.approx(expected, rel=1e-10)


def test_viscous_damping_dissipates_at_the_right_rate(robot_loader) -> None:  # type: ignore[no-untyped-def]
    # pendulum with damping d: dE/dt = -d v^2 (exactly); compare E(T) - E(0) with -int d v^2
    robot = robot_loader("pendulum")
    d = 0.3
    opts = SimulationOptions(friction=JointFriction(damping=d))
    traj = simulate(robot, None, (np.array([1.0]), np.zeros(1)), 3.0, 1e-3, opts)
    power = -d * traj.v[:, 0] ** 2
    dissipated = np.trapezoid(power, traj.t)
    e = traj.total_energy
    assert e[-1] - e[0] == pytest.approx(dissipated, rel=1e-4)


def test_coulomb_friction_is_smoothed_sign(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("pendulum")
    dyn = ForwardDynamics(robot, JointFriction(coulomb=2.0, coulomb_smoothing=1e-3))
    assert dyn.friction_torque(np.array([1.0]))[0] == pytest.approx(-2.0)
    assert dyn.friction_torque(np.array([-1.0]))[0] == pytest.approx(2.0)
    assert dyn.friction_torque(np.array([0.0]))[0] == 0.0


def test_forward_dynamics_matches_mass_matrix(panda: Robot, rng: np.random.Generator) -> None:
    q, v, tau = panda.random_configuration(rng), rng.normal(size=7), rng.normal(size=7)
    data = panda.model.createData()
    M = pin.crba(panda.model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    F = pin.nonLinearEffects(panda.model, data, q, v)
    np.testing.assert_allclose(
        forward_dynamics(panda, q, v, tau), np.linalg.solve(M, tau - F), atol=1e-9
    )


def test_floating_base_free_fall_keeps_quaternion(talos: Robot) -> None:
    q0 = talos.q_default
    traj = simulate(
        talos, None, (q0, np.zeros(talos.nv)), 0.2, 2e-3, SimulationOptions(record_energy=False)
    )
    assert traj.success
    quat = traj.q[:, 3:7]
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
    # free fall of the whole body: the base drops by g t^2 / 2 (the joints are free too,
    # but the center of mass falls exactly)
    data = talos.model.createData()
    c0 = pin.centerOfMass(talos.model, data, traj.q[0]).copy()
    c1 = pin.centerOfMass(talos.model, data, traj.q[-1]).copy()
    assert c1[2] - c0[2] == pytest.approx(-0.5 * 9.81 * 0.2**2, rel=1e-6)
    np.testing.assert_allclose(c1[:2], c0[:2], atol=1e-9)


def test_pid_integral_removes_steady_state_error() -> None:
    # constant disturbance force F: PD leaves the offset F/kp (analytic); PID follows the
    # linear ODE of the extended state (slide 5:15), solved with the matrix exponential
    from scipy.linalg import expm

    from taskspace.control import point_mass_pid_matrix

    mass, force, ki = 1.0, 2.0, 20.0
    robot = point_mass_robot(mass)
    gains = PIDGains.from_wavelength(mass, wavelength=0.25, damping_ratio=1.0)
    pd = PIDController(gains, target=0.0)
    pid = PIDController(PIDGains(kp=gains.kp, kd=gains.kd, ki=ki), target=0.0)

    def disturbed(ctrl):  # type: ignore[no-untyped-def]
        return lambda t, q, v: ctrl(t, q, v) + force

    x0 = (np.zeros(1), np.zeros(1))
    a = simulate(robot, disturbed(pd), x0, 6.0, 1e-3)
    b = simulate(robot, disturbed(pid), x0, 6.0, 1e-3)
    assert a.q[-1, 0] == pytest.approx(force / gains.kp, rel=1e-6)
    A = point_mass_pid_matrix(mass, gains.kp, gains.kd, ki)
    z_star = np.array([0.0, 0.0, -force / ki])
    ref = np.array([z_star + expm(A * t) @ (np.zeros(3) - z_star) for t in b.t[::100]])
    assert np.max(np.abs(b.q[::100, 0] - ref[:, 0])) < 2e-3  # zero-order hold: O(dt)
    assert abs(b.q[-1, 0]) < 1e-3 < 0.1 < a.q[-1, 0]  # integral action removes the offset


def test_pid_anti_windup_reduces_overshoot() -> None:
    robot = point_mass_robot(1.0)
    gains = PIDGains(kp=20.0, kd=6.0, ki=30.0)
    x0 = (np.zeros(1), np.zeros(1))
    results = {}
    for anti in (False, True):
        from taskspace.control import PIDOptions

        pid = PIDController(gains, 1.0, options=PIDOptions(output_limit=2.0, anti_windup=anti))
        traj = simulate(robot, pid, x0, 8.0, 2e-3)
        results[anti] = traj.q[:, 0].max() - 1.0
        assert np.all(np.abs(traj.tau) <= 2.0 + 1e-12)
    assert results[True] < 0.5 * results[False]


# ---------------------------------------------------------------- error paths
def test_simulate_error_paths(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("pendulum")
    x0 = (np.zeros(1), np.zeros(1))
    with pytest.raises(InvalidInputError, match=r"dt \(time step \[s\]\) must be finite and > 0"):
        simulate(robot, None, x0, 1.0, 0.0)
    with pytest.raises(InvalidInputError, match=r"T \(duration \[s\]\) must be finite and > 0"):
        simulate(robot, None, x0, -1.0, 0.01)
    with pytest.raises(InvalidInputError, match="dt must not exceed T"):
        simulate(robot, None, x0, 0.01, 0.1)
    with pytest.raises(InvalidInputError, match="unknown integrator 'euler'; valid integrators"):
        simulate(robot, None, x0, 1.0, 0.01, SimulationOptions(integrator="euler"))
    with pytest.raises(InvalidInputError, match="controller must be callable"):
        simulate(robot, 3.0, x0, 1.0, 0.01)  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match=r"controller torque at t=0 must have shape \(1,\)"):
        simulate(robot, lambda t, q, v: np.zeros(2), x0, 1.0, 0.01)
    with pytest.raises(NotFiniteError, match="controller torque at t=0 has non-finite"):
        simulate(robot, lambda t, q, v: np.array([np.nan]), x0, 1.0, 0.01)
    with pytest.raises(NotFiniteError, match="x0\\[0\\] \\(q0\\) has non-finite"):
        simulate(robot, None, (np.array([np.nan]), np.zeros(1)), 1.0, 0.01)
    with pytest.raises(ShapeError, match=r"x0 \(q0 and v0 concatenated\) must have shape \(2,\)"):
        simulate(robot, None, np.zeros(3), 1.0, 0.01)
    with pytest.raises(InvalidInputError, match="friction damping must be finite and >= 0"):
        simulate(robot, None, x0, 1.0, 0.01, SimulationOptions(friction=JointFriction(damping=-1)))


def test_divergence_is_reported(robot_loader) -> None:  # type: ignore[no-untyped-def]
    robot = robot_loader("pendulum")
    # a destabilizing controller: positive feedback on velocity
    traj = simulate(
        robot,
        lambda t, q, v: 50.0 * v,
        (np.array([0.1]), np.array([1.0])),
        5.0,
        0.01,
        SimulationOptions(max_velocity=1e3),
    )
    assert not traj.success
    assert traj.status is SimulationStatus.DIVERGED
    assert "state diverged" in traj.message
    assert np.all(np.isfinite(traj.q))
    assert traj.t.size == traj.q.shape[0] == traj.tau.shape[0]
