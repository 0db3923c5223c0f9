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

import numpy as np
from gymnasium import spaces

from taskspace.errors import InvalidInputError
from taskspace.learning.envs.robot_env import RobotEnv, RobotVectorEnv
from taskspace.optimal_control.problems import cartpole_acceleration

THETA_LIMIT = 12 * 2 * np.pi / 360
X_LIMIT = 2.4


def _spaces() -> tuple[spaces.Discrete, spaces.Box]:
    high = np.array([2 * X_LIMIT, np.inf, 2 * THETA_LIMIT, np.inf], dtype=np.float32)
    return spaces.Discrete(2), spaces.Box(-high, high, dtype=np.float32)


class CartPoleEnv(RobotEnv):
    """Cart-pole balancing; registered as ``taskspace/CartPole-v0`` (500 steps).

    Args:
        force: push magnitude [N]; dt: control period [s]; substeps: ABA steps per period.
        render_mode: ``None``, ``"rgb_array"`` (a 400 x 400 x 3 image) or ``"human"``.
    """

    metadata = {**RobotEnv.metadata, "render_fps": 50}  # noqa: RUF012

    def __init__(
        self,
        force: float = 10.0,
        dt: float = 0.02,
        substeps: int = 2,
        render_mode: str | None = None,
    ) -> None:
        super().__init__("cartpole", dt, substeps, render_mode)
        self.force = float(force)
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
        self._after_step()
        return self._obs(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Push for ``dt`` (ABA + semi-implicit Euler substeps)."""
        if not self.action_space.contains(action):
            raise InvalidInputError(f"action must be 0 or 1, got {action!r}")
        tau = np.array([self.force if int(action) == 1 else -self.force, 0.0])
        self.q, self.v = self._integrate(self.q, self.v, tau)
        terminated = bool(abs(self.q[0]) > X_LIMIT or abs(self.q[1]) > THETA_LIMIT)
        self._after_step()
        return self._obs(), 1.0, terminated, False, {}

    def _draw(self, ax: Any) -> None:
        """Track, cart and pole (0.5 m drawn as 1 m, as Gymnasium's picture)."""
        x, th = float(self.q[0]), float(self.q[1])
        ax.set_xlim(-X_LIMIT - 0.3, X_LIMIT + 0.3)
        ax.set_ylim(-0.6, 1.6)
        ax.axis("off")
        ax.plot([-X_LIMIT, X_LIMIT], [0.0, 0.0], color="0.3", lw=1)
        ax.add_patch(_rectangle((x - 0.25, -0.075), 0.5, 0.15, color="#34495e"))
        tip = (x + np.sin(th), np.cos(th))
        ax.plot([x, tip[0]], [0.0, tip[1]], color="#c0392b", lw=6, solid_capstyle="round")


def _rectangle(xy: tuple[float, float], width: float, height: float, **kw: Any) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(xy, width, height, **kw)


class CartPoleVectorEnv(RobotVectorEnv):
    """N cart-poles stepped together (numpy, no loop over copies), auto-reset on termination.

    Same dynamics, rewards and termination as :class:`CartPoleEnv`; truncation after
    ``max_episode_steps``. Registered as ``taskspace/CartPole-v0``'s vector entry point:
    ``gymnasium.make_vec("taskspace/CartPole-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``.
    """

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
        super().__init__(num_envs, dt, substeps, max_episode_steps, render_mode)
        self.force = float(force)
        self._set_spaces(*_spaces())
        self.q = np.zeros((self.num_envs, 2))
        self.v = np.zeros((self.num_envs, 2))

    def _obs(self) -> np.ndarray:
        return np.stack([self.q[:, 0], self.v[:, 0], self.q[:, 1], self.v[:, 1]], axis=1).astype(
            np.float32
        )

    def _reset_copies(self, mask: np.ndarray) -> None:
        """States uniform in ``[-0.05, 0.05]``."""
        s = self.np_random.uniform(-0.05, 0.05, (int(mask.sum()), 4))
        if np.all(mask):
            self.q, self.v = s[:, :2].copy(), s[:, 2:].copy()
        else:
            self.q[mask], self.v[mask] = s[:, :2], s[:, 2:]

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
        self._autoreset(reward, terminated, truncated)
        return self._obs(), reward, terminated, truncated, {}
