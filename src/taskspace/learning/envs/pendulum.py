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
