"""Gymnasium pendulum swing-up on the registry's ``pendulum`` robot (Pinocchio ABA dynamics).

State ``(theta, theta')`` with ``theta = 0`` hanging down (the URDF's convention); the task is
to hold the pendulum upright (``theta = pi``) with a bounded torque. Observation
``[cos(theta - pi), sin(theta - pi), theta']`` (the upright is ``[1, 0, 0]``, as in
Gymnasium's ``Pendulum-v1``), reward ``-(wrap(theta - pi)^2 + 0.1 theta'^2 + 0.001 u^2)``.

The single environment steps Pinocchio's ABA in closed form: for one revolute joint on a fixed
base ABA is ``theta'' = (u - g(theta)) / I`` with a constant inertia ``I`` and a gravity torque
``g = g_s sin(theta) + g_c cos(theta) + g_0``; :class:`RevoluteJointDynamics` reads ``I`` and
``g`` from the model (CRBA, generalized gravity), checks the closed form against ``pin.aba`` at
a few random states when the environment is built, and the substeps then run on Python floats
(no Pinocchio call, no array per substep). A model that fails the check is stepped with
``pin.aba``.

Thread safety: an environment (single or batched) is a simulation state and is not thread-safe:
one environment per thread. Shared use is detected: ``reset``/``step`` raise
:class:`~taskspace.errors.ConcurrentUseError` while another thread is inside one of them (see
:mod:`taskspace.learning.envs.robot_env`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
from gymnasium import spaces

from taskspace.dynamics.pendulum import pendulum_acceleration
from taskspace.learning.envs.robot_env import (
    RobotEnv,
    RobotVectorEnv,
    action_array,
    one_thread_at_a_time,
    snap_roundoff,
)
from taskspace.model.versioning import ModelFollower

_PI = math.pi
_TWO_PI = 2.0 * math.pi


def _wrap(a: float) -> float:
    return float((a + _PI) % _TWO_PI - _PI)


def _scalar_action(action: Any) -> float:
    """The first entry of an action (a ``(1,)`` array, a sequence or a number) as a float."""
    if type(action) is np.ndarray and action.size == 1:
        value = float(action.item())
        if value == value:  # not NaN
            return value
    return float(action_array(action, (1,))[0])


class RevoluteJointDynamics:
    """Pinocchio's ABA of a fixed-base robot with one revolute joint, in closed form.

    ``theta'' = (tau - g_s sin(theta) - g_c cos(theta) - g_0) / I`` (no velocity term: one
    joint on a fixed base has no Coriolis torque). Build it with :meth:`from_model`, which
    returns ``None`` when the model is not of that kind (checked against ``pin.aba``).

    Attributes:
        inertia: ``I`` [kg m^2] (the joint's CRBA entry, rotor inertia included).
        gravity: ``(g_s, g_c, g_0)`` [N m].
    """

    def __init__(self, inertia: float, gravity: tuple[float, ...]) -> None:
        self.inertia = float(inertia)
        self.gravity = (float(gravity[0]), float(gravity[1]), float(gravity[2]))
        self._inv_inertia = 1.0 / self.inertia

    @classmethod
    def from_model(cls, model: Any, data: Any, rtol: float = 1e-10) -> RevoluteJointDynamics | None:
        """Read ``I`` and ``g`` from the model; ``None`` unless ABA agrees to ``rtol``."""
        if model.nq != 1 or model.nv != 1:
            return None
        inertia = float(pin.crba(model, data, np.zeros(1))[0, 0])
        g0, g90, g180 = (
            float(pin.computeGeneralizedGravity(model, data, np.array([th]))[0])
            for th in (0.0, 0.5 * _PI, _PI)
        )
        # g(0) = g_c + g_0, g(pi) = -g_c + g_0 (up to sin(pi) ~ 1e-16), g(pi/2) = g_s + g_0.
        offset = 0.5 * (g0 + g180)
        dyn = cls(inertia, snap_roundoff((g90 - offset, 0.5 * (g0 - g180), offset)))
        rng = np.random.default_rng(0)
        for _ in range(8):
            q, v, tau = rng.uniform(-4.0, 4.0, 3)
            ref = float(pin.aba(model, data, np.array([q]), np.array([v]), np.array([tau]))[0])
            if not abs(dyn.acceleration(q, tau) - ref) <= rtol * (1.0 + abs(ref)):
                return None
        return dyn

    def acceleration(self, theta: float, tau: float) -> float:
        """``theta''`` [rad/s^2] at angle ``theta`` [rad] under torque ``tau`` [N m]."""
        gs, gc, g0 = self.gravity
        return (tau - gs * math.sin(theta) - gc * math.cos(theta) - g0) * self._inv_inertia

    def integrate(
        self, theta: float, omega: float, tau: float, h: float, substeps: int, max_speed: float
    ) -> tuple[float, float]:
        """``substeps`` semi-implicit Euler steps of ``h`` [s], ``|omega| <= max_speed``."""
        gs, gc, g0 = self.gravity
        inv_i = self._inv_inertia
        sin, cos = math.sin, math.cos
        for _ in range(substeps):
            omega = omega + h * ((tau - gs * sin(theta) - gc * cos(theta) - g0) * inv_i)
            if omega > max_speed:
                omega = max_speed
            elif omega < -max_speed:
                omega = -max_speed
            theta = theta + h * omega
        return theta, omega


class PendulumEnv(RobotEnv):
    """Pendulum swing-up; registered as ``taskspace/Pendulum-v0`` (200 steps).

    Args:
        max_torque: torque bound [N m] (below ``m g l`` = 9.81 N m: the pendulum must swing).
        dt: control period [s]; substeps: ABA + semi-implicit Euler steps per period.
        max_speed: velocity bound [rad/s].
        render_mode: ``None``, ``"rgb_array"`` (a 400 x 400 x 3 image) or ``"human"``.
    """

    def __init__(
        self,
        max_torque: float = 5.0,
        dt: float = 0.05,
        substeps: int = 5,
        max_speed: float = 8.0,
        render_mode: str | None = None,
    ) -> None:
        super().__init__("pendulum", dt, substeps, render_mode)
        self.max_torque = float(max_torque)
        self.max_speed = float(max_speed)
        self.action_space = spaces.Box(-self.max_torque, self.max_torque, (1,), np.float32)
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.state = np.zeros(2)
        self.dynamics: RevoluteJointDynamics | None = None
        """Closed-form ABA of the model (``None``: stepped with ``pin.aba``); derived again
        after ``robot.edit_model`` (the robot's version)."""
        self._dynamics_follower = ModelFollower(self.robot, "PendulumEnv", self._derive_dynamics)

    def _derive_dynamics(self) -> None:
        self.dynamics = RevoluteJointDynamics.from_model(self._model, self.data)

    @property
    def q(self) -> np.ndarray:
        """The robot's configuration (size 1): the angle [rad] (for viewers)."""
        return self.state[:1].copy()

    def _obs(self) -> np.ndarray:
        th, w = self.state.tolist()
        return np.array([math.cos(th - _PI), math.sin(th - _PI), w], dtype=np.float32)

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Random angle in ``[-pi, pi)`` and velocity in ``[-1, 1]`` rad/s."""
        super().reset(seed=seed)
        self.state = np.array(
            [self.np_random.uniform(-np.pi, np.pi), self.np_random.uniform(-1, 1)]
        )
        self._after_step()
        return self._obs(), {}

    @one_thread_at_a_time
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the clipped torque for ``dt`` (ABA, semi-implicit Euler substeps)."""
        u = _scalar_action(action)
        u = min(max(u, -self.max_torque), self.max_torque)
        th, w = self.state.tolist()
        d = (th - _PI + _PI) % _TWO_PI - _PI  # wrap(th - pi)
        reward = -(d * d + 0.1 * w * w + 0.001 * u * u)
        self._dynamics_follower.sync()  # one comparison unless the robot was edited
        if self.dynamics is not None:
            th, w = self.dynamics.integrate(
                th, w, u, self.dt / self.substeps, self.substeps, self.max_speed
            )
        else:
            q, v = self._integrate(np.array([th]), np.array([w]), np.array([u]), self.max_speed)
            th, w = float(q[0]), float(v[0])
        th = (th + _PI) % _TWO_PI - _PI
        self.state = np.array([th, w])
        if self.render_mode == "human":
            self.render()
        return (
            np.array([math.cos(th - _PI), math.sin(th - _PI), w], dtype=np.float32),
            reward,
            False,
            False,
            {},
        )

    def _draw(self, ax: Any) -> None:
        """The pole (length 1 m, angle from hanging down) and the applied torque's sign."""
        th = float(self.state[0])
        tip = (np.sin(th), -np.cos(th))
        ax.set_xlim(-1.3, 1.3)
        ax.set_ylim(-1.3, 1.3)
        ax.set_aspect("equal")
        ax.axis("off")
        ax.plot([0.0, tip[0]], [0.0, tip[1]], color="#c0392b", lw=10, solid_capstyle="round")
        ax.plot(0.0, 0.0, "ko", ms=8)


class PendulumVectorEnv(RobotVectorEnv):
    """N pendulums stepped together with numpy (no loop over copies), auto-reset.

    Same dynamics (the closed form :func:`taskspace.dynamics.pendulum.pendulum_acceleration`
    of the registry's pendulum: 1 kg at 1 m), rewards and observations as
    :class:`PendulumEnv`; truncation after ``max_episode_steps``. The vector entry point of
    ``taskspace/Pendulum-v0``.
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        max_torque: float = 5.0,
        dt: float = 0.05,
        substeps: int = 5,
        max_speed: float = 8.0,
        max_episode_steps: int = 200,
        render_mode: str | None = None,
    ) -> None:
        super().__init__(num_envs, dt, substeps, max_episode_steps, render_mode)
        self.max_torque = float(max_torque)
        self.max_speed = float(max_speed)
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self._set_spaces(
            spaces.Box(-self.max_torque, self.max_torque, (1,), np.float32),
            spaces.Box(-high, high, dtype=np.float32),
        )
        self.state = np.zeros((self.num_envs, 2))

    def _obs(self) -> np.ndarray:
        th, w = self.state[:, 0], self.state[:, 1]
        return np.stack([np.cos(th - np.pi), np.sin(th - np.pi), w], axis=1).astype(np.float32)

    def _sample(self, k: int) -> np.ndarray:
        return np.stack(
            [self.np_random.uniform(-np.pi, np.pi, k), self.np_random.uniform(-1, 1, k)], axis=1
        )

    def _reset_copies(self, mask: np.ndarray) -> None:
        """As :meth:`PendulumEnv.reset`."""
        if np.all(mask):
            self.state = self._sample(self.num_envs)
        else:
            self.state[mask] = self._sample(int(mask.sum()))

    @one_thread_at_a_time
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy; copies that ended on the previous step are reset instead."""
        u = np.clip(
            action_array(actions, (self.num_envs,), "actions"),
            -self.max_torque,
            self.max_torque,
        )
        th, w = self.state[:, 0].copy(), self.state[:, 1].copy()
        d = (th - np.pi + np.pi) % (2 * np.pi) - np.pi
        reward = -(d**2 + 0.1 * w**2 + 0.001 * u**2)
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            w = np.clip(w + h * pendulum_acceleration(th, u), -self.max_speed, self.max_speed)
            th = th + h * w
        self.state = np.stack([(th + np.pi) % (2 * np.pi) - np.pi, w], axis=1)
        self.steps += 1
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = self.steps >= self.max_episode_steps
        self._autoreset(reward, terminated, truncated)
        return self._obs(), reward, terminated, truncated, {}
