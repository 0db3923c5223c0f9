"""Gymnasium pendulum swing-up on the registry's ``pendulum`` robot (Pinocchio ABA dynamics).

State ``(theta, theta')`` with ``theta = 0`` hanging down (the URDF's convention); the task is
to hold the pendulum upright (``theta = pi``) with a bounded torque. Observation
``[cos(theta - pi), sin(theta - pi), theta']`` (the upright is ``[1, 0, 0]``, as in
Gymnasium's ``Pendulum-v1``), reward ``-(wrap(theta - pi)^2 + 0.1 theta'^2 + 0.001 u^2)``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pinocchio as pin
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from taskspace.dynamics.pendulum import pendulum_acceleration
from taskspace.errors import InvalidInputError
from taskspace.model.robot import Robot


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class PendulumEnv(gym.Env[np.ndarray, np.ndarray]):
    """Pendulum swing-up; registered as ``taskspace/Pendulum-v0`` (200 steps).

    Args:
        max_torque: torque bound [N m] (below ``m g l`` = 9.81 N m: the pendulum must swing).
        dt: control period [s]; substeps: ABA + semi-implicit Euler steps per period.
        render_mode: only ``None`` (no rendering yet).
    """

    metadata = {"render_modes": [], "render_fps": 20}  # noqa: RUF012

    def __init__(
        self,
        max_torque: float = 5.0,
        dt: float = 0.05,
        substeps: int = 5,
        max_speed: float = 8.0,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use None")
        self.robot = Robot.load("pendulum")
        self.model = self.robot.model
        self.data = self.model.createData()
        self.max_torque = float(max_torque)
        self.max_speed = float(max_speed)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.render_mode = render_mode
        self.action_space = spaces.Box(-self.max_torque, self.max_torque, (1,), np.float32)
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.state = np.zeros(2)

    def _obs(self) -> np.ndarray:
        th, w = self.state
        return np.array([np.cos(th - np.pi), np.sin(th - np.pi), w], dtype=np.float32)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Random angle in ``[-pi, pi)`` and velocity in ``[-1, 1]`` rad/s."""
        super().reset(seed=seed)
        self.state = np.array(
            [self.np_random.uniform(-np.pi, np.pi), self.np_random.uniform(-1, 1)]
        )
        return self._obs(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the clipped torque for ``dt`` (ABA, semi-implicit Euler substeps)."""
        u = float(
            np.clip(
                np.asarray(action, dtype=float).reshape(-1)[0], -self.max_torque, self.max_torque
            )
        )
        th, w = self.state
        reward = -(_wrap(th - np.pi) ** 2 + 0.1 * w**2 + 0.001 * u**2)
        h = self.dt / self.substeps
        q, v, tau = np.array([th]), np.array([w]), np.array([u])
        for _ in range(self.substeps):
            a = pin.aba(self.model, self.data, q, v, tau)
            v = np.clip(v + h * a, -self.max_speed, self.max_speed)
            q = q + h * v
        self.state = np.array([_wrap(float(q[0])), float(v[0])])
        return self._obs(), float(reward), False, False, {}


class PendulumVectorEnv(VectorEnv):
    """N pendulums stepped together with numpy (no loop over copies), auto-reset.

    Same dynamics (the closed form :func:`taskspace.dynamics.pendulum.pendulum_acceleration`
    of the registry's pendulum: 1 kg at 1 m), rewards and observations as
    :class:`PendulumEnv`; truncation after ``max_episode_steps``. The vector entry point of
    ``taskspace/Pendulum-v0``.
    """

    metadata = {"render_modes": [], "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}  # noqa: RUF012

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
        if render_mode is not None:
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use None")
        if num_envs < 1:
            raise InvalidInputError(f"num_envs must be >= 1, got {num_envs}")
        self.num_envs = int(num_envs)
        self.max_torque = float(max_torque)
        self.max_speed = float(max_speed)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.max_episode_steps = int(max_episode_steps)
        self.render_mode = render_mode
        self.single_action_space = spaces.Box(-self.max_torque, self.max_torque, (1,), np.float32)
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self.single_observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.state = np.zeros((self.num_envs, 2))
        self.steps = np.zeros(self.num_envs, dtype=np.int64)
        self.prev_done = np.zeros(self.num_envs, dtype=bool)

    def _obs(self) -> np.ndarray:
        th, w = self.state[:, 0], self.state[:, 1]
        return np.stack([np.cos(th - np.pi), np.sin(th - np.pi), w], axis=1).astype(np.float32)

    def _sample(self, k: int) -> np.ndarray:
        return np.stack(
            [self.np_random.uniform(-np.pi, np.pi, k), self.np_random.uniform(-1, 1, k)], axis=1
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every copy (as :meth:`PendulumEnv.reset`)."""
        super().reset(seed=seed)
        self.state = self._sample(self.num_envs)
        self.steps[:] = 0
        self.prev_done[:] = False
        return self._obs(), {}

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy; copies that ended on the previous step are reset instead."""
        u = np.clip(
            np.asarray(actions, dtype=float).reshape(self.num_envs),
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
        done = self.prev_done
        if np.any(done):
            self.state[done] = self._sample(int(done.sum()))
            self.steps[done] = 0
            reward[done] = 0.0
            truncated[done] = False
        self.prev_done = truncated.copy()
        return self._obs(), reward, terminated, truncated, {}
