"""The closed-form steps of the pendulum and cart-pole envs against Pinocchio's ABA.

References: ``pin.aba`` on the registry URDFs (an independent implementation of the same
dynamics) and, for the pendulum, the analytic ``(u - m g l sin theta) / (m l^2)``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.learning.envs import CartPoleEnv, PendulumEnv
from taskspace.learning.envs.cartpole import CartPoleDynamics
from taskspace.learning.envs.pendulum import RevoluteJointDynamics
from taskspace.model.robot import Robot


def test_pendulum_closed_form_is_aba_and_the_analytic_pendulum() -> None:
    env = PendulumEnv()
    dyn = env.dynamics
    assert dyn is not None
    # The registry's pendulum: 1 kg at 1 m, g = 9.81: I = 1, g(theta) = 9.81 sin(theta).
    assert dyn.inertia == pytest.approx(1.0, rel=1e-12)
    assert dyn.gravity == pytest.approx((9.81, 0.0, 0.0), abs=1e-12)
    rng = np.random.default_rng(1)
    for q, v, tau in rng.uniform(-7, 7, (50, 3)):
        ref = pin.aba(env.model, env.data, np.array([q]), np.array([v]), np.array([tau]))[0]
        assert dyn.acceleration(q, tau) == pytest.approx(ref, rel=1e-12, abs=1e-12)
        assert dyn.acceleration(q, tau) == pytest.approx(tau - 9.81 * np.sin(q), abs=1e-12)


def _aba_rollout(model, data, q, v, taus, dt, substeps, max_speed=np.inf):  # type: ignore[no-untyped-def]
    """The reference: ``substeps`` x (ABA, v += h a, clip, q += h v) per control step."""
    h = dt / substeps
    out = []
    for tau in taus:
        for _ in range(substeps):
            v = np.clip(v + h * pin.aba(model, data, q, v, tau), -max_speed, max_speed)
            q = q + h * v
        out.append((q.copy(), v.copy()))
    return out


def test_pendulum_steps_follow_aba_substeps() -> None:
    # max_speed 3 rad/s is reached from the swing: the clip is exercised too.
    env = PendulumEnv(max_torque=5.0, substeps=5, max_speed=3.0)
    env.reset(seed=0)
    env.state = np.array([2.5, 0.0])
    taus = np.random.default_rng(2).uniform(-5, 5, (60, 1)).astype(np.float32).astype(float)
    ref = _aba_rollout(
        env.model, env.data, np.array([2.5]), np.zeros(1), taus, env.dt, 5, max_speed=3.0
    )
    clipped = 0
    for tau, (q, v) in zip(taus, ref, strict=True):
        obs, *_ = env.step(tau.astype(np.float32))
        wrapped = (q[0] + np.pi) % (2 * np.pi) - np.pi
        assert env.state == pytest.approx([wrapped, v[0]], abs=1e-9)
        assert obs == pytest.approx([np.cos(q[0] - np.pi), np.sin(q[0] - np.pi), v[0]], abs=1e-6)
        clipped += abs(v[0]) == 3.0
    assert clipped > 0


def test_cartpole_closed_form_is_aba() -> None:
    env = CartPoleEnv()
    dyn = env.dynamics
    assert dyn is not None
    rng = np.random.default_rng(3)
    for _ in range(50):
        q, v, tau = rng.uniform(-3, 3, (3, 2))
        ref = pin.aba(env.model, env.data, q, v, tau)
        assert dyn.acceleration(*q, *v, *tau) == pytest.approx(ref, rel=1e-12, abs=1e-12)


def test_cartpole_steps_follow_aba_substeps() -> None:
    env = CartPoleEnv(substeps=4)
    env.reset(seed=0)
    q0, v0 = np.array([0.1, 0.15]), np.array([-0.3, 0.5])  # falls within the episode
    env.q, env.v = q0.copy(), v0.copy()
    acts = np.random.default_rng(4).integers(0, 2, 80)
    taus = [np.array([10.0 if a else -10.0, 0.0]) for a in acts]
    ref = _aba_rollout(env.model, env.data, q0, v0, taus, env.dt, 4)
    for a, (q, v) in zip(acts, ref, strict=True):
        obs, _, terminated, _, _ = env.step(int(a))
        assert env.q == pytest.approx(q, abs=1e-10)
        assert env.v == pytest.approx(v, abs=1e-10)
        assert obs == pytest.approx([q[0], v[0], q[1], v[1]], abs=1e-5)
        assert terminated == (abs(q[0]) > 2.4 or abs(q[1]) > 12 * np.pi / 180)


def test_without_the_closed_form_the_envs_step_with_aba() -> None:
    pend = PendulumEnv()
    pend.reset(seed=0)
    fast = PendulumEnv()
    fast.reset(seed=0)
    pend.dynamics = None
    cart = CartPoleEnv()
    cart.reset(seed=0)
    cart_fast = CartPoleEnv()
    cart_fast.reset(seed=0)
    cart.dynamics = None
    for k in range(20):
        o1, r1, *_ = pend.step(np.array([2.0], dtype=np.float32))
        o2, r2, *_ = fast.step(np.array([2.0], dtype=np.float32))
        assert o1 == pytest.approx(o2, abs=1e-6) and r1 == pytest.approx(r2, rel=1e-9)
        assert cart.step(k % 2)[0] == pytest.approx(cart_fast.step(k % 2)[0], abs=1e-6)


def test_from_model_rejects_other_robots() -> None:
    double = Robot.load("double_pendulum")
    data = double.model.createData()
    # Two revolute joints: the pole's inertia about its joint varies with the elbow angle.
    assert CartPoleDynamics.from_model(double.model, data) is None
    assert RevoluteJointDynamics.from_model(double.model, data) is None
