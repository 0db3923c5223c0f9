"""Gymnasium balance task on the G1 humanoid, the inverse-dynamics QP as the low level.

The G1 stands on both feet (two 6-D contacts with friction cones and centre-of-pressure
limits). At reset its base receives a random horizontal push (a base velocity). The agent
acts every ``dt`` by shifting the centre-of-mass reference, ``c* = c_0 + 0.05 a`` [m] with
``a`` in ``[-1, 1]^3``; between actions the inverse-dynamics QP
(:class:`taskspace.control.InverseDynamicsQP`: CoM task, posture, contacts, torque limits)
computes the torques every ``sim_dt`` and the rigid-contact dynamics
(:func:`taskspace.control.simulate_with_contacts`) advance the robot.

Observation ``[c - c_0, c']`` (6) [m, m/s]; reward ``1 - 100 |c_xy - c_0,xy|^2 -
0.01 |a|^2`` per step (alive bonus minus the horizontal CoM error); the episode terminates
when a foot would lift (normal force below 1 N, the rigid contact pulling), when the CoM
leaves a 10 cm disc around ``c_0`` or when the QP fails.

Model version: the env follows ``robot.version`` as :class:`PandaReachEnv` does (through a
:class:`taskspace.model.ModelFollower`). :meth:`G1BalanceEnv.reset` re-derives the torque
limits (:attr:`G1BalanceEnv.tau_max`; the inverse-dynamics QP re-reads them too) when
:meth:`Robot.set_limits` gave the robot a new version; a :meth:`G1BalanceEnv.step` after such a
change, before a reset, raises :class:`~taskspace.errors.StaleModelError` (an episode runs
under one set of limits).

Thread safety: an environment (single or batched) is a simulation state and is not thread-safe:
one environment per thread. Shared use is detected: ``reset``/``step`` raise
:class:`~taskspace.errors.ConcurrentUseError` while another thread is inside one of them (see
:mod:`taskspace.learning.envs.robot_env`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pinocchio as pin
from gymnasium import spaces

from taskspace.constraints import Contact6D
from taskspace.control import InverseDynamicsQP, simulate_with_contacts
from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.features import CenterOfMass, JointConfiguration
from taskspace.learning.envs.robot_env import action_array, check_render_mode, one_thread_at_a_time
from taskspace.model.robot import Robot
from taskspace.model.versioning import ModelFollower
from taskspace.tasks import Task

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
COM_RANGE = 0.05  # [m] CoM reference offset of a unit action
MIN_NORMAL_FORCE = 1.0  # [N]
MAX_COM_ERROR = 0.1  # [m]


class G1BalanceEnv(gym.Env[np.ndarray, np.ndarray]):
    """G1 balancing after a push; registered as ``taskspace/G1Balance-v0`` (100 steps).

    Args:
        robot: a loaded ``g1`` (``None``: load it; pass one robot to many environments).
        dt: period of the agent's actions [s]; sim_dt: control and simulation step [s].
        push: the base's initial horizontal velocity is uniform in ``[-push, push]^2`` [m/s].
        render_mode: only ``None``.
    """

    metadata = {"render_modes": [], "render_fps": 50}  # noqa: RUF012

    def __init__(
        self,
        robot: Robot | None = None,
        dt: float = 0.02,
        sim_dt: float = 0.004,
        push: float = 0.3,
        render_mode: str | None = None,
    ) -> None:
        self.render_mode = check_render_mode(render_mode, ())
        self.robot = robot if robot is not None else Robot.load("g1")
        missing = [f for f in FEET if f not in self.robot.frame_names]
        if missing or self.robot.nq == self.robot.nv:
            raise InvalidInputError(
                f"G1BalanceEnv needs the registry's floating-base 'g1' robot with frames {FEET}"
            )
        if not (0 < sim_dt <= dt) or abs(dt / sim_dt - round(dt / sim_dt)) > 1e-9:
            raise InvalidInputError(
                f"need 0 < sim_dt <= dt with dt a multiple of sim_dt, got dt={dt}, sim_dt={sim_dt}"
            )
        self.dt, self.sim_dt, self.push = float(dt), float(sim_dt), float(push)
        robot = self.robot
        self._state = robot.state(robot.q_default, np.zeros(robot.nv))
        contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
        self.com_task = Task(CenterOfMass(robot), kp=50.0, priority=0, name="com")
        self.com_task.set_target_from_state(self._state)
        self.c0 = np.array(self.com_task.target, dtype=float)
        posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
        self.controller = InverseDynamicsQP(robot, [self.com_task, posture], contacts)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (6,), np.float32)
        self._data = robot._model.createData()
        self.q = robot.q_default.copy()
        self.v = np.zeros(robot.nv)
        self._follower = ModelFollower(robot, "G1BalanceEnv", self._read_limits)

    def _read_limits(self) -> None:
        """Copy the robot's torque limits (called again at a reset after a new version)."""
        self.tau_max = self.robot.effort_limits.copy()

    @property
    def model_version(self) -> int:
        """The robot version the current episode runs under."""
        return self._follower.version

    def _check_version(self) -> None:
        """Raise :class:`StaleModelError` if the robot's limits changed since the reset."""
        if self._follower.stale:
            raise StaleModelError(
                f"G1BalanceEnv: the limits of robot '{self.robot.name}' changed during the "
                f"episode (Robot.set_limits: version {self._follower.version} -> "
                f"{self.robot.version}); call reset() to start an episode under the new limits",
                self._follower.version,
                self.robot.version,
            )

    def _com(self) -> tuple[np.ndarray, np.ndarray]:
        c = pin.centerOfMass(self.robot._model, self._data, self.q, self.v)
        return np.array(c), np.array(self._data.vcom[0])

    def _obs(self) -> np.ndarray:
        c, vc = self._com()
        return np.concatenate([c - self.c0, vc]).astype(np.float32)

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Default posture; base velocity ``[vx, vy, 0]`` uniform in ``[-push, push]``.

        Re-derives the torque limits if the robot's version changed.
        """
        super().reset(seed=seed)
        self._follower.sync()
        self.controller.reset()  # no warm start carried over: episodes are reproducible
        self.q = self.robot.q_default.copy()
        self.v = np.zeros(self.robot.nv)
        # The free-flyer velocity is in the base frame (upright at the default posture).
        self.v[:2] = self.np_random.uniform(-self.push, self.push, 2)
        return self._obs(), {}

    @one_thread_at_a_time
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Set the CoM reference and simulate ``dt`` under the inverse-dynamics QP.

        ``info["max_torque_ratio"]`` is ``max |tau_i| / tau_max_i`` over the step (<= 1).

        Raises:
            StaleModelError: the robot's limits changed since the last reset.
        """
        self._check_version()
        a = np.clip(action_array(action, (3,)), -1.0, 1.0)
        self.com_task.set_target(self.c0 + COM_RANGE * a)
        failed: list[str] = []
        ratio = [0.0]
        actuated = self.tau_max > 0.0

        def control(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
            self._state.update(q, v)
            result = self.controller.solve(self._state)
            if not result.success:
                failed.append(result.status.value)
            tau = result.tau
            ratio[0] = max(ratio[0], float(np.max(np.abs(tau[actuated]) / self.tau_max[actuated])))
            return tau

        rollout = simulate_with_contacts(
            self.robot, control, self.q, self.v, self.dt, self.sim_dt, FEET
        )
        self.q, self.v = rollout.q[-1].copy(), rollout.v[-1].copy()
        normal = min(float(f[:, 2].min()) for f in rollout.forces.values())
        total = sum(float(f[-1, 2]) for f in rollout.forces.values())
        c, _ = self._com()
        error = float(np.linalg.norm(c[:2] - self.c0[:2]))
        reward = 1.0 - 100.0 * error**2 - 0.01 * float(a @ a)
        lifted = normal < MIN_NORMAL_FORCE
        terminated = bool(lifted or error > MAX_COM_ERROR or failed)
        info = {
            "min_normal_force": normal,
            "total_normal_force": total,
            "com_error": error,
            "qp_failures": failed,
            "max_torque_ratio": ratio[0],
        }
        return self._obs(), reward, terminated, False, info
