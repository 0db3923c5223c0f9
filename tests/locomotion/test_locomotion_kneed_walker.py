"""Kneed walker: Pinocchio dynamics, knee-strike and heel-strike impacts, limit cycle.

References: the equations of motion written out by hand (Hsu Chen 2007, eq. 3.2, in her
angles ``q = (-theta_st, theta_th, theta_sh)``); the compass gait's hand-derived model for the
locked phase and heel strike; energies and angular momenta computed here from the point
masses' positions and velocities alone; Carnot's theorem for plastic impacts; Hsu Chen's
published gait (thesis sec. 3.3) and an independent reproduction of it.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, SolverError
from taskspace.locomotion import CompassGait, LimitCycleOptions
from taskspace.locomotion.kneed_walker import (
    KneedWalker,
    find_kneed_limit_cycle,
    kneed_return_map,
    simulate_kneed_step,
)

# Hsu Chen's published post-heel-strike state: q = (0.1877, -0.2884, -0.2884),
# qd = (-1.1014, -0.0399, -0.0399), i.e. z = (theta_st, dtheta_st, dtheta_sw) below
PUBLISHED = np.array([-0.1877, 1.1014, -0.0399])
MASSES = (
    "stance_shank_mass",
    "stance_thigh_mass",
    "hip",
    "swing_thigh_mass",
    "swing_shank_mass",
)
SWING_LEG = ("swing_thigh_mass", "swing_shank_mass")
STANCE_LEG = ("stance_shank_mass", "stance_thigh_mass")
# heel strike: the same bodies before and after (the legs swap roles)
SAME = {
    "stance_shank_mass": "swing_shank_mass",
    "stance_thigh_mass": "swing_thigh_mass",
    "hip": "hip",
    "swing_thigh_mass": "stance_thigh_mass",
    "swing_shank_mass": "stance_shank_mass",
}


@pytest.fixture(scope="module")
def walker():
    return KneedWalker()


@pytest.fixture(scope="module")
def cycle(walker):
    return find_kneed_limit_cycle(walker, PUBLISHED)


@pytest.fixture(scope="module")
def step(walker, cycle):
    return simulate_kneed_step(walker, cycle.post_impact, samples=80)


# ------------------------------------------------------------------ independent references
def _kinematics(w, x):
    """Point positions and velocities from the angles, written out by hand."""
    st, th, sh, dst, dth, dsh = x
    up, dup = np.array([np.sin(st), np.cos(st)]), dst * np.array([np.cos(st), -np.sin(st)])
    down_t, ddown_t = np.array([np.sin(th), -np.cos(th)]), dth * np.array([np.cos(th), np.sin(th)])
    down_s, ddown_s = np.array([np.sin(sh), -np.cos(sh)]), dsh * np.array([np.cos(sh), np.sin(sh)])
    ls, lt, L = w.shank_length, w.thigh_length, w.leg_length
    p = {
        "stance_shank_mass": w.a1 * up,
        "stance_thigh_mass": (ls + w.a2) * up,
        "hip": L * up,
        "swing_thigh_mass": L * up + w.b2 * down_t,
        "knee": L * up + lt * down_t,
        "swing_shank_mass": L * up + lt * down_t + w.b1 * down_s,
        "swing_foot": L * up + lt * down_t + ls * down_s,
    }
    v = {
        "stance_shank_mass": w.a1 * dup,
        "stance_thigh_mass": (ls + w.a2) * dup,
        "hip": L * dup,
        "swing_thigh_mass": L * dup + w.b2 * ddown_t,
        "knee": L * dup + lt * ddown_t,
        "swing_shank_mass": L * dup + lt * ddown_t + w.b1 * ddown_s,
        "swing_foot": L * dup + lt * ddown_t + ls * ddown_s,
    }
    return p, v


def _mass(w, name):
    if name == "hip":
        return w.hip_mass
    return w.thigh_mass if "thigh" in name else w.shank_mass


def _kinetic(w, x):
    _, v = _kinematics(w, x)
    return sum(0.5 * _mass(w, n) * v[n] @ v[n] for n in MASSES)


def _energy(w, x):
    p, _ = _kinematics(w, x)
    return _kinetic(w, x) + sum(_mass(w, n) * w.gravity * p[n][1] for n in MASSES)


def _cross(r, v):
    return r[0] * v[1] - r[1] * v[0]


def _momentum(w, x, names, about):
    p, v = _kinematics(w, x)
    return sum(_mass(w, n) * _cross(p[n] - about, v[n]) for n in names)


def _hsu_chen_acceleration(w, q, qd, locked):
    """Hsu Chen's eq. 3.2: H(q) qdd + B(q, qd) qd + G(q) = 0, her angles and her matrices."""
    mh, mt, ms, g = w.hip_mass, w.thigh_mass, w.shank_mass, w.gravity
    a1, b1, a2, b2 = w.a1, w.b1, w.a2, w.b2
    ls, lt, L = a1 + b1, a2 + b2, a1 + b1 + a2 + b2
    H11 = ms * a1**2 + mt * (ls + a2) ** 2 + (mh + ms + mt) * L**2
    G1 = -(ms * a1 + mt * (ls + a2) + (mh + mt + ms) * L) * g * np.sin(q[0])
    if locked:  # the swing leg as one rigid body, both masses below the hip
        k12 = -(mt * b2 + ms * (lt + b1)) * L
        H = np.array([[H11, k12 * np.cos(q[0] - q[1])], [0.0, mt * b2**2 + ms * (lt + b1) ** 2]])
        H[1, 0] = H[0, 1]
        c = np.array(
            [k12 * np.sin(q[0] - q[1]) * qd[1] ** 2, -k12 * np.sin(q[0] - q[1]) * qd[0] ** 2]
        )
        G = np.array([G1, (mt * b2 + ms * (lt + b1)) * g * np.sin(q[1])])
        return np.linalg.solve(H, -(c + G))
    k = {(0, 1): -(mt * b2 + ms * lt) * L, (0, 2): -ms * b1 * L, (1, 2): ms * lt * b1}
    H = np.diag([H11, mt * b2**2 + ms * lt**2, ms * b1**2])
    c = np.zeros(3)
    for (i, j), kij in k.items():
        H[i, j] = H[j, i] = kij * np.cos(q[i] - q[j])
        # d/dt dT/dqd_i - dT/dq_i has k_ij sin(q_i - q_j) qd_j^2 for H_ij = k_ij cos(q_i - q_j)
        c[i] += kij * np.sin(q[i] - q[j]) * qd[j] ** 2
        c[j] += kij * np.sin(q[j] - q[i]) * qd[i] ** 2
    G = np.array([G1, (mt * b2 + ms * lt) * g * np.sin(q[1]), ms * b1 * g * np.sin(q[2])])
    return np.linalg.solve(H, -(c + G)), H


# ------------------------------------------------------------------ tests
@pytest.mark.parametrize(
    "params",
    [{}, {"hip_mass": 0.7, "thigh_mass": 0.4, "shank_mass": 0.1, "a1": 0.3, "b1": 0.2, "a2": 0.1}],
    ids=["hsu_chen", "asymmetric"],
)
def test_dynamics_equal_the_hand_derived_lagrangian(params):
    walker = KneedWalker(**params)
    rng = np.random.default_rng(3)
    sign3, sign2 = np.array([-1.0, 1.0, 1.0]), np.array([-1.0, 1.0])
    for _ in range(5):
        x = np.concatenate((rng.uniform(-0.6, 0.6, 3), rng.uniform(-2.0, 2.0, 3)))
        qdd, H = _hsu_chen_acceleration(walker, sign3 * x[:3], sign3 * x[3:], locked=False)
        assert walker.unlocked_dynamics(x)[3:] == pytest.approx(sign3 * qdd, rel=1e-10, abs=1e-10)
        assert walker.mass_matrix(x[:3]) == pytest.approx(
            np.outer(sign3, sign3) * H, rel=1e-12, abs=1e-12
        )
        y = x[[0, 1, 3, 4]]
        qdd2 = _hsu_chen_acceleration(walker, sign2 * y[:2], sign2 * y[2:], locked=True)
        assert walker.locked_dynamics(y)[2:] == pytest.approx(sign2 * qdd2, rel=1e-10, abs=1e-10)
        assert walker.energy(x) == pytest.approx(_energy(walker, x), rel=1e-12, abs=1e-12)
        p, _ = _kinematics(walker, x)
        for name, point in walker.positions(x[:3]).items():
            assert point == pytest.approx(p[name], abs=1e-14)


def test_locked_phase_and_heel_strike_are_the_compass_gait():
    # a (nearly) massless thigh: the locked legs carry m_s at a1 from the foot, as the compass
    # gait carries m at a (its own hand-derived Lagrangian and momentum-balance impact map)
    kneed = KneedWalker(thigh_mass=1e-12, shank_mass=5.0, hip_mass=10.0)
    compass = CompassGait(hip_mass=10.0, leg_mass=5.0, leg_length=1.0, a=kneed.a1, slope=0.0504)
    rng = np.random.default_rng(4)
    for _ in range(5):
        y = np.concatenate((rng.uniform(-0.5, 0.5, 2), rng.uniform(-2.0, 2.0, 2)))
        assert kneed.locked_dynamics(y) == pytest.approx(compass.dynamics(y), rel=1e-9, abs=1e-9)
        pre = np.array([y[0], y[1], y[1], y[2], y[3], y[3]])
        post = kneed.impact(pre)
        assert post[[0, 1, 3, 4]] == pytest.approx(compass.impact(y), rel=1e-9, abs=1e-9)
        assert post[2] == post[1] and post[5] == post[4]


def test_fixed_point_satisfies_return_map(walker, cycle):
    assert cycle.success and cycle.iterations <= 8
    z = cycle.fixed_point
    assert np.abs(kneed_return_map(walker, z) - z).max() < 1e-10
    # Hsu Chen's published gait (her fixed-step integration, 4 digits): within 1 %
    assert z == pytest.approx(PUBLISHED, abs=2e-2 * abs(PUBLISHED[1]))
    assert z[:2] == pytest.approx(PUBLISHED[:2], rel=1e-2)
    interleg = -cycle.post_impact[0] - cycle.post_impact[1]
    assert interleg == pytest.approx(0.4761, rel=5e-3)  # her sec. 3.3.2
    assert cycle.period == pytest.approx(0.559, rel=2e-2)  # read from her figure
    # an independent reproduction (nyasuto/crane, sympy-derived equations, angles from the
    # slope normal): y* = (0.23859, -1.10959, -0.05715), period 0.5643 s, multipliers
    # 0.353 +- 0.552i and 0.144
    crane = np.array([-(0.23859 - walker.slope), 1.10959, -0.05715])
    assert z == pytest.approx(crane, abs=2e-5)
    assert cycle.period == pytest.approx(0.5643, abs=1e-4)
    mults = sorted(cycle.floquet_multipliers, key=lambda m: (abs(m), m.imag))
    assert mults[0] == pytest.approx(0.144, abs=1e-3)
    assert abs(mults[1]) == pytest.approx(abs(0.353 + 0.552j), abs=1e-3)
    assert cycle.stable and np.abs(cycle.floquet_multipliers).max() < 0.7
    # the Jacobian predicts the map of a small perturbation
    dz = 1e-5 * np.array([1.0, -2.0, 0.5])
    assert kneed_return_map(walker, z + dz) - z == pytest.approx(cycle.jacobian @ dz, abs=1e-7)


def test_perturbed_gait_returns_to_cycle(walker, cycle):
    z = cycle.fixed_point + np.array([0.005, -0.02, 0.02])
    for _ in range(12):
        z = kneed_return_map(walker, z, rtol=1e-10, atol=1e-10)
    assert np.abs(z - cycle.fixed_point).max() < 1e-3


def test_energy_conserved_in_each_phase(walker, step):
    assert step.success and 0.0 < step.knee_strike_time < step.duration
    unlocked = step.times < step.knee_strike_time
    locked = step.times > step.knee_strike_time
    assert unlocked.sum() > 10 and locked.sum() > 10
    for phase in (unlocked, locked):
        energies = np.array([_energy(walker, x) for x in step.states[phase]])
        assert np.ptp(energies) < 1e-9 * abs(energies).max()
    # the knee bends, then locks straight
    flexion = step.states[unlocked, 1] - step.states[unlocked, 2]
    assert flexion.max() > 0.3 and (flexion[1:] > 0).all()
    assert np.all(step.states[locked, 1] == step.states[locked, 2])


def test_swing_foot_clears_the_slope(walker, step):
    # on this gait the swing foot never touches the slope between heel strikes (it lifts off
    # at once and passes mid-stance ~19 mm above)
    feet = np.array([_kinematics(walker, x)[0]["swing_foot"] for x in step.states])
    height = feet[:, 1] + feet[:, 0] * np.tan(walker.slope)
    assert (height[1:-1] > 0.0).all()
    i = int(np.argmax(feet[:, 0] > 0.0))
    assert np.interp(0.0, feet[i - 1 : i + 1, 0], height[i - 1 : i + 1]) > 0.015


def test_knee_strike_conserves_angular_momenta_and_loses_carnot_energy(walker, step):
    pre, post = step.pre_knee_strike, step.post_knee_strike
    assert post[:3] == pytest.approx(pre[:3], abs=0)
    assert post[5] == post[4]
    origin = np.zeros(2)
    hip = _kinematics(walker, pre)[0]["hip"]
    # whole walker about the stance foot, swing leg about the hip
    assert _momentum(walker, post, MASSES, origin) == pytest.approx(
        _momentum(walker, pre, MASSES, origin), rel=1e-12
    )
    assert _momentum(walker, post, SWING_LEG, hip) == pytest.approx(
        _momentum(walker, pre, SWING_LEG, hip), rel=1e-10
    )
    # Carnot: kinetic energy lost = kinetic energy of the velocity jumps
    _, v_pre = _kinematics(walker, pre)
    _, v_post = _kinematics(walker, post)
    jump = sum(0.5 * _mass(walker, n) * np.sum((v_pre[n] - v_post[n]) ** 2) for n in MASSES)
    assert _kinetic(walker, pre) - _kinetic(walker, post) == pytest.approx(jump, rel=1e-9)
    assert jump > 1e-4 * _kinetic(walker, pre)
    # the knee's impulsive torque stops the shank's rotation relative to the thigh
    assert step.knee_impulse < 0.0


def test_heel_strike_conserves_angular_momenta_and_loses_carnot_energy(walker, step):
    pre, post = step.pre_impact, step.post_impact
    p_pre, v_pre = _kinematics(walker, pre)
    p_post, v_post = _kinematics(walker, post)
    shift = p_pre["swing_foot"]  # the new frame's origin in the old frame
    assert shift[1] == pytest.approx(-shift[0] * np.tan(walker.slope), abs=1e-12)
    for n in MASSES:
        assert p_post[SAME[n]] == pytest.approx(p_pre[n] - shift, abs=1e-12)
    # whole walker about the new stance foot, trailing leg about the hip
    assert _momentum(walker, post, MASSES, np.zeros(2)) == pytest.approx(
        _momentum(walker, pre, MASSES, shift), rel=1e-12
    )
    assert _momentum(walker, post, SWING_LEG, p_post["hip"]) == pytest.approx(
        _momentum(walker, pre, STANCE_LEG, p_pre["hip"]), rel=1e-10
    )
    # Carnot on the velocity jumps of each body
    jump = sum(0.5 * _mass(walker, n) * np.sum((v_pre[n] - v_post[SAME[n]]) ** 2) for n in MASSES)
    loss = _kinetic(walker, pre) - _kinetic(walker, post)
    assert loss == pytest.approx(jump, rel=1e-9)
    # the ground pushes up, and the old stance foot leaves the slope
    assert step.heel_impulse[1] > 0.0
    normal = np.array([np.sin(walker.slope), np.cos(walker.slope)])
    assert v_post["swing_foot"] @ normal > 0.0
    # over a period the two impact losses equal one step's potential energy drop
    knee_loss = _kinetic(walker, step.pre_knee_strike) - _kinetic(walker, step.post_knee_strike)
    total = walker.hip_mass + 2 * (walker.thigh_mass + walker.shank_mass)
    assert loss + knee_loss == pytest.approx(total * walker.gravity * -shift[1], rel=1e-8)


def _accelerations(w, x, qdd):
    """Point accelerations, by hand: sum_j l_j (qdd_j u'(theta_j) - qd_j^2 u(theta_j))."""
    st, th, sh, dst, dth, dsh = x

    def up(d):  # d (sin, cos)(theta_st), differentiated twice in time
        s, c = np.sin(st), np.cos(st)
        return d * (qdd[0] * np.array([c, -s]) - dst**2 * np.array([s, c]))

    def down(d, a, da, dda):
        s, c = np.sin(a), np.cos(a)
        return d * (dda * np.array([c, s]) - da**2 * np.array([s, -c]))

    ls, lt, L = w.shank_length, w.thigh_length, w.leg_length
    return {
        "stance_thigh_mass": up(ls + w.a2),
        "hip": up(L),
        "swing_thigh_mass": up(L) + down(w.b2, th, dth, qdd[1]),
        "swing_shank_mass": up(L) + down(lt, th, dth, qdd[1]) + down(w.b1, sh, dsh, qdd[2]),
    }


def test_knee_lock_torques_from_moment_balance(walker, step):
    # the torque on the body above a joint = sum m (r - r_joint) x (a + g e_y) over that body
    ls = walker.shank_length
    stance_knee = ls * np.array([np.sin(step.states[:, 0]), np.cos(step.states[:, 0])]).T
    stance_torques, swing_torques = [], []
    for t, x, knee in zip(step.times, step.states, stance_knee, strict=True):
        locked = t > step.knee_strike_time
        tau = walker.knee_lock_torques(x, swing_knee_locked=locked)
        if locked:
            xdot = walker.locked_dynamics(x[[0, 1, 3, 4]])
            qdd = np.array([xdot[2], xdot[3], xdot[3]])
        else:
            qdd = walker.unlocked_dynamics(x)[3:]
        p, _ = _kinematics(walker, x)
        a = _accelerations(walker, x, qdd)
        g = np.array([0.0, walker.gravity])
        upper = ("stance_thigh_mass", "hip", "swing_thigh_mass", "swing_shank_mass")
        # positive stance-knee torque pushes the thigh back (counterclockwise): into flexion
        ref = sum(_mass(walker, n) * _cross(p[n] - knee, a[n] + g) for n in upper)
        assert tau[0] == pytest.approx(ref, abs=1e-10)
        shank = _mass(walker, "swing_shank_mass") * _cross(
            p["swing_shank_mass"] - p["knee"], a["swing_shank_mass"] + g
        )
        assert tau[1] == pytest.approx(-shank if locked else 0.0, abs=1e-10)
        assert np.abs(tau[2:]).max() < 1e-10  # the passive stance foot and hip
        stance_torques.append(tau[0])
        if locked:
            swing_torques.append(tau[1])
    # the swing knee presses into its stop after the knee strike (no latch needed); the
    # stance knee needs a latch early in the step (it would buckle), a stop later
    assert min(swing_torques) > 0.0
    stance_torques = np.array(stance_torques)
    assert stance_torques.min() < 0.0 < stance_torques.max()
    assert (stance_torques[step.times > 0.4 * step.duration] > 0.0).all()


def test_falls_and_errors(walker, cycle):
    with pytest.raises(SolverError, match="return map undefined"):
        kneed_return_map(walker, [-0.2, 0.2, -1.0])
    with pytest.raises(InvalidInputError, match="thigh_mass must be finite and > 0"):
        KneedWalker(thigh_mass=0.0)
    with pytest.raises(InvalidInputError, match="b1 > 0 and b2 > 0"):
        KneedWalker(b1=0.0)
    bent = cycle.post_impact.copy()
    bent[2] -= 0.1
    with pytest.raises(InvalidInputError, match="swing knee straight"):
        simulate_kneed_step(walker, bent)
    # a fast stance leg: the bent swing leg's foot hits the slope mid-swing (located there)
    sw = -0.19 - 2 * walker.slope
    scuff = simulate_kneed_step(walker, [-0.19, sw, sw, 1.6, 0.5, 0.5])
    assert not scuff.success and "hit the slope before its knee locked" in scuff.message
    foot = _kinematics(walker, scuff.pre_impact)[0]["swing_foot"]
    assert foot[1] + foot[0] * np.tan(walker.slope) == pytest.approx(0.0, abs=1e-9)
    assert walker.knee_flexion(scuff.pre_impact) > 0.1 and 0.1 < scuff.duration < 0.4
    bad = find_kneed_limit_cycle(walker, PUBLISHED, LimitCycleOptions(max_iterations=1))
    assert not bad.success and bad.residual > 1e-6
