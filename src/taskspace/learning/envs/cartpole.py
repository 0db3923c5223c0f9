"""Gymnasium cart-pole on the registry's ``cartpole`` robot (Pinocchio ABA dynamics).

The classic balancing task of Barto, Sutton and Anderson as in Gymnasium's ``CartPole-v1``:
state ``(x, theta, x', theta')`` of the URDF (``theta = 0`` upright; cart 1 kg, pole 0.1 kg
point mass at 0.5 m), two actions pushing the cart with ``-F`` or ``+F`` [N], reward 1 per
step, termination when ``|theta| > 12 deg`` or ``|x| > 2.4 m``. Observation
``[x, x', theta, theta']`` (Gymnasium's order).

:class:`CartPoleVectorEnv` steps N copies at once with the closed-form equations of motion
of the same point-mass cart-pole (:func:`taskspace.optimal_control.cartpole_acceleration`,
checked against ABA in the tests), without a Python loop over the copies.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pinocchio as pin
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from taskspace.errors import InvalidInputError
from taskspace.model.robot import Robot
from taskspace.optimal_control.problems import cartpole_acceleration

THETA_LIMIT = 12 * 2 * np.pi / 360
X_LIMIT = 2.4


def _spaces() -> tuple[spaces.Discrete, spaces.Box]:
    high = np.array([2 * X_LIMIT, np.inf, 2 * THETA_LIMIT, np.inf], dtype=np.float32)
    return spaces.Discrete(2), spaces.Box(-high, high, dtype=np.float32)


class CartPoleEnv(gym.Env[np.ndarray, np.int64]):
    """Cart-pole balancing; registered as ``taskspace/CartPole-v0`` (500 steps).

    Args:
        force: push magnitude [N]; dt: control period [s]; substeps: ABA steps per period.
        render_mode: only ``None`` (no rendering yet).
    """

    metadata = {"render_modes": [], "render_fps": 50}  # noqa: RUF012

    def __init__(
        self,
        force: float = 10.0,
        dt: float = 0.02,
        substeps: int = 2,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use None")
        self.robot = Robot.load("cartpole")
        self.model = self.robot.model
        self.data = self.model.createData()
        self.force = float(force)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.render_mode = render_mode
        self.action_space, self.observation_space = _spaces()
        self.q = np.zeros(2)
        self.v = np.zeros(2)

    def _obs(self) -> np.ndarray:
        return np.array([self.q[0], self.v[0], self.q[1], self.v[1]], dtype=np.float32)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Every state component uniform in ``[-0.05, 0.05]``."""
        super().reset(seed=seed)
        s = self.np_random.uniform(-0.05, 0.05, 4)
        self.q = s[:2].copy()
        self.v = s[2:].copy()
        return self._obs(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Push for ``dt`` (ABA + semi-implicit Euler substeps)."""
        if not self.action_space.contains(action):
            raise InvalidInputError(f"action must be 0 or 1, got {action!r}")
        tau = np.array([self.force if int(action) == 1 else -self.force, 0.0])
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            a = pin.aba(self.model, self.data, self.q, self.v, tau)
            self.v = self.v + h * a
            self.q = self.q + h * self.v
        terminated = bool(abs(self.q[0]) > X_LIMIT or abs(self.q[1]) > THETA_LIMIT)
        return self._obs(), 1.0, terminated, False, {}


class CartPoleVectorEnv(VectorEnv):
    """N cart-poles stepped together (numpy, no loop over copies), auto-reset on termination.

    Same dynamics, rewards and termination as :class:`CartPoleEnv`; truncation after
    ``max_episode_steps``. Registered as ``taskspace/CartPole-v0``'s vector entry point:
    ``gymnasium.make_vec("taskspace/CartPole-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``.
    """

    metadata = {"render_modes": [], "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}  # noqa: RUF012

    def __init__(
        self,
        num_envs: int = 1,
        *,
        force: float = 10.0,
        dt: float = 0.02,
        substeps: int = 2,
        max_episode_steps: int = 500,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use None")
        if num_envs < 1:
            raise InvalidInputError(f"num_envs must be >= 1, got {num_envs}")
        self.num_envs = int(num_envs)
        self.force = float(force)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.max_episode_steps = int(max_episode_steps)
        self.render_mode = render_mode
        self.single_action_space, self.single_observation_space = _spaces()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.q = np.zeros((self.num_envs, 2))
        self.v = np.zeros((self.num_envs, 2))
        self.steps = np.zeros(self.num_envs, dtype=np.int64)
        self.prev_done = np.zeros(self.num_envs, dtype=bool)

    def _obs(self) -> np.ndarray:
        return np.stack([self.q[:, 0], self.v[:, 0], self.q[:, 1], self.v[:, 1]], axis=1).astype(
            np.float32
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every copy (states uniform in ``[-0.05, 0.05]``)."""
        super().reset(seed=seed)
        s = self.np_random.uniform(-0.05, 0.05, (self.num_envs, 4))
        self.q, self.v = s[:, :2].copy(), s[:, 2:].copy()
        self.steps[:] = 0
        self.prev_done[:] = False
        return self._obs(), {}

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy; copies that ended on the previous step are reset instead."""
        act = np.asarray(actions).reshape(self.num_envs)
        if not np.all((act == 0) | (act == 1)):
            raise InvalidInputError("actions must be 0 or 1")
        F = np.where(act == 1, self.force, -self.force)
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            a = cartpole_acceleration(self.q, self.v, F)
            self.v = self.v + h * a
            self.q = self.q + h * self.v
        self.steps += 1
        terminated = (np.abs(self.q[:, 0]) > X_LIMIT) | (np.abs(self.q[:, 1]) > THETA_LIMIT)
        truncated = self.steps >= self.max_episode_steps
        reward = np.ones(self.num_envs)
        done = self.prev_done
        if np.any(done):
            k = int(done.sum())
            s = self.np_random.uniform(-0.05, 0.05, (k, 4))
            self.q[done], self.v[done] = s[:, :2], s[:, 2:]
            self.steps[done] = 0
            reward[done] = 0.0
            terminated[done] = False
            truncated[done] = False
        self.prev_done = terminated | truncated
        return self._obs(), reward, terminated, truncated, {}
