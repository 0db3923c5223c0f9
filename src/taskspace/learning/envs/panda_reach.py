"""Gymnasium reaching task on the Panda: joint-velocity actions, collision-aware termination.

Each step applies joint velocities ``v = a * v_max`` (``a`` in ``[-1, 1]^7``) for ``dt``, with
``q`` kept inside the joint limits. Observation ``[q (7), p_tcp (3), p_target (3)]`` [rad, m];
reward ``-|p_tcp - p_target| - 0.01 |a|^2``; the episode terminates with ``+10`` when the tool
centre point is within ``tolerance`` of the target, and with ``-10`` when the configuration is
in collision (self-collision or obstacles of ``robot.world``, exact mesh checks of
:class:`taskspace.planning.collision_checker.CollisionChecker`).

Model version: the joint limits (position and velocity) and the observation space follow
``robot.version``. :meth:`PandaReachEnv.reset` re-derives them when :meth:`Robot.set_limits`
gave the robot a new version; a :meth:`PandaReachEnv.step` after such a change, before a
reset, raises :class:`~taskspace.errors.StaleModelError` (the episode ran under other limits).

Thread safety: an environment (single or batched) is a simulation state and is not thread-safe:
one environment per thread. Shared use is detected: ``reset``/``step`` raise
:class:`~taskspace.errors.ConcurrentUseError` while another thread is inside one of them (see
:mod:`taskspace.learning.envs.robot_env`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.learning.envs.batched_kinematics import BatchedFramePosition
from taskspace.learning.envs.robot_env import RobotVectorEnv, action_array, one_thread_at_a_time
from taskspace.model.robot import Robot
from taskspace.planning.collision_checker import CollisionChecker

TARGET_LOW = np.array([0.3, -0.4, 0.2])
TARGET_HIGH = np.array([0.7, 0.4, 0.7])


def _check_robot(robot: Any, who: str) -> None:
    """Refuse a robot other than a 7-joint arm of one-dof joints with the Panda's tool frame.

    The env's state is ``q`` (7) moved by ``q + dt v`` with one velocity limit per entry: a
    joint with several coordinates (free-flyer, spherical, planar) or whose ``nq`` differs
    from its ``nv`` (continuous) breaks that (a free-flyer alone has ``nq = 7``). Pinocchio's
    joints are read for the message.

    Raises:
        InvalidInputError: ``robot`` is not a :class:`Robot`, lacks ``panda_hand_tcp`` or has
            other joints than 7 one-dof ones (named with their ``nq`` and ``nv``).
    """
    if not isinstance(robot, Robot):
        raise InvalidInputError(f"{who} needs a taskspace Robot, got {type(robot).__name__}")
    model = robot._model
    multi = [
        f"{model.names[j]} (nq={model.joints[j].nq}, nv={model.joints[j].nv})"
        for j in range(1, model.njoints)
        if model.joints[j].nq != 1 or model.joints[j].nv != 1
    ]
    if multi or robot.nv != 7 or robot.nq != 7 or "panda_hand_tcp" not in robot.frame_names:
        detail = f"joints with other than one coordinate: {multi}" if multi else ""
        if not detail:
            detail = (
                f"nq={robot.nq}, nv={robot.nv}"
                if robot.nv != 7 or robot.nq != 7
                else "no frame 'panda_hand_tcp'"
            )
        raise InvalidInputError(
            f"{who} needs the registry's 'panda' robot (7 one-dof joints and the frame "
            f"'panda_hand_tcp'); robot '{robot.name}' has {detail}"
        )


def _velocity_joint_names(robot: Robot) -> list[str]:
    """The name of the joint of each velocity coordinate (Pinocchio's ``idx_v`` and ``nv``)."""
    model = robot._model
    names = [""] * model.nv
    for j in range(1, model.njoints):
        joint = model.joints[j]
        names[joint.idx_v : joint.idx_v + joint.nv] = [model.names[j]] * joint.nv
    return names


def _limits(robot: Any) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, spaces.Box]:
    """Robot version, copied position and velocity limits, and the observation space.

    The space bounds (q, tcp, target); its ``q`` entries are ``-inf``/``+inf`` for a joint
    without position limits. The actions are fractions of the velocity limits, so every joint
    needs a finite one.

    Raises:
        InvalidInputError: a joint without a finite velocity limit (``v = a * inf`` made
            the joint jump to its position limit in one step, and ``a = 0`` gave NaN).
    """
    v_max = robot.velocity_limits.copy()
    if not np.all(np.isfinite(v_max)):
        names = _velocity_joint_names(robot)
        bad = list(dict.fromkeys(names[i] for i in np.flatnonzero(~np.isfinite(v_max))))
        raise InvalidInputError(
            f"PandaReach needs a finite velocity limit on every joint (an action is a fraction "
            f"of it); unlimited: {bad} (Robot.set_limits(velocity=...))"
        )
    lower = robot.lower_limits.copy()
    upper = robot.upper_limits.copy()
    low = np.concatenate([lower, [-2.0] * 3, TARGET_LOW]).astype(np.float32)
    high = np.concatenate([upper, [2.0] * 3, TARGET_HIGH]).astype(np.float32)
    box = spaces.Box(low, high, dtype=np.float32)
    return robot.version, lower, upper, v_max, box


class PandaReachEnv(gym.Env[np.ndarray, np.ndarray]):
    """Panda reaching; registered as ``taskspace/PandaReach-v0`` (100 steps).

    Args:
        robot: a loaded ``panda`` (``None``: load it; loading takes seconds, so pass one robot
            to many environments).
        dt: control period [s]; tolerance: success distance [m].
        render_mode: only ``None`` (no rendering yet).
    """

    metadata = {"render_modes": [], "render_fps": 10}  # noqa: RUF012

    def __init__(
        self,
        robot: Robot | None = None,
        dt: float = 0.1,
        tolerance: float = 0.02,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use None")
        self.robot = robot if robot is not None else Robot.load("panda")
        _check_robot(self.robot, "PandaReachEnv")
        self.checker = CollisionChecker(self.robot)
        self.dt = float(dt)
        self.tolerance = float(tolerance)
        self.render_mode = render_mode
        self.action_space = spaces.Box(-1.0, 1.0, (7,), np.float32)
        self._read_limits()
        self.q = self.robot.q_default.copy()
        self.target = 0.5 * (TARGET_LOW + TARGET_HIGH)

    def _read_limits(self) -> None:
        """Copy the robot's limits and build the observation space; record the version."""
        self.model_version, self.lower, self.upper, self.v_max, box = _limits(self.robot)
        self.observation_space = box

    def _check_version(self) -> None:
        """Raise :class:`StaleModelError` if the robot's limits changed since the reset."""
        if self.robot.version != self.model_version:
            raise StaleModelError(
                f"PandaReachEnv: the limits of robot '{self.robot.name}' changed during the "
                f"episode (Robot.set_limits: version {self.model_version} -> "
                f"{self.robot.version}); call reset() to start an episode under the new limits",
                self.model_version,
                self.robot.version,
            )

    def tcp(self) -> np.ndarray:
        """Tool centre point position [m]."""
        return np.asarray(self.robot.frame_placement(self.q, "panda_hand_tcp").translation)

    def _obs(self, tcp: np.ndarray | None = None) -> np.ndarray:
        tcp = self.tcp() if tcp is None else tcp
        return np.concatenate([self.q, tcp, self.target]).astype(np.float32)

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Default posture perturbed by up to 0.1 rad per joint; target uniform in a box.

        Re-derives the joint limits and the observation space if the robot's version changed.
        """
        super().reset(seed=seed)
        if self.robot.version != self.model_version:
            self._read_limits()
        for _ in range(100):
            q = self.robot.q_default + self.np_random.uniform(-0.1, 0.1, 7)
            q = np.clip(q, self.lower, self.upper)
            if self.checker.is_valid(q):
                break
        self.q = q
        self.target = self.np_random.uniform(TARGET_LOW, TARGET_HIGH)
        return self._obs(), {"distance": float(np.linalg.norm(self.tcp() - self.target))}

    @one_thread_at_a_time
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move with the commanded joint velocities for ``dt``.

        Raises:
            StaleModelError: the robot's limits changed since the last reset.
        """
        self._check_version()
        a = np.clip(action_array(action, (7,)), -1.0, 1.0)
        self.q = np.clip(self.q + self.dt * a * self.v_max, self.lower, self.upper)
        tcp = self.tcp()
        distance = float(np.linalg.norm(tcp - self.target))
        reward = -distance - 0.01 * float(a @ a)
        collision = not self.checker.is_valid(self.q)
        reached = distance < self.tolerance
        if collision:
            reward -= 10.0
        elif reached:
            reward += 10.0
        info = {"distance": distance, "collision": collision, "success": reached and not collision}
        return self._obs(tcp), reward, bool(collision or reached), False, info


class PandaReachVectorEnv(RobotVectorEnv):
    """N Panda reaching tasks stepped together, auto-reset on the next step.

    Same actions, observations, rewards and termination as :class:`PandaReachEnv`, without a
    Python loop over the copies: the joint update is one array operation, the tool positions
    come from :class:`~taskspace.learning.envs.batched_kinematics.BatchedFramePosition` (the
    chain's forward kinematics on N configurations at once) and the collision flags from one
    :meth:`CollisionChecker.are_valid` call (the compiled collision kernel when built).
    Truncation after ``max_episode_steps``. The vector entry point of
    ``taskspace/PandaReach-v0``. Info: ``distance``, ``collision`` and ``success`` arrays
    (with their ``_distance``... masks, as ``gymnasium.vector`` merges infos).

    Model version: as :class:`PandaReachEnv`; :meth:`reset` re-derives the limits and the
    spaces after :meth:`Robot.set_limits`, a step before that raises
    :class:`~taskspace.errors.StaleModelError`.

    Args:
        num_envs: number of copies N.
        robot: a loaded ``panda`` (``None``: load it).
        dt: control period [s]; tolerance: success distance [m].
        max_episode_steps: truncation length.
        render_mode: only ``None``.
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        robot: Robot | None = None,
        dt: float = 0.1,
        tolerance: float = 0.02,
        max_episode_steps: int = 100,
        render_mode: str | None = None,
    ) -> None:
        super().__init__(num_envs, dt, 1, max_episode_steps, render_mode)
        self.robot = robot if robot is not None else Robot.load("panda")
        _check_robot(self.robot, "PandaReachVectorEnv")
        self.checker = CollisionChecker(self.robot)
        self.tcp_position = BatchedFramePosition(self.robot._model, "panda_hand_tcp")
        self.tolerance = float(tolerance)
        self._read_limits()
        self.q = np.tile(self.robot.q_default, (self.num_envs, 1))
        self.target = np.tile(0.5 * (TARGET_LOW + TARGET_HIGH), (self.num_envs, 1))
        self._tcp = self.tcp_position(self.q)

    def _read_limits(self) -> None:
        self.model_version, self.lower, self.upper, self.v_max, box = _limits(self.robot)
        self._set_spaces(spaces.Box(-1.0, 1.0, (7,), np.float32), box)

    def _obs(self) -> np.ndarray:
        return np.concatenate([self.q, self._tcp, self.target], axis=1).astype(np.float32)

    def _reset_copies(self, mask: np.ndarray) -> None:
        """As :meth:`PandaReachEnv.reset`: a collision-free perturbed default posture, a target."""
        idx = np.flatnonzero(mask)
        q = np.empty((idx.size, 7))
        todo = np.arange(idx.size)
        for _ in range(100):
            draw = self.robot.q_default + self.np_random.uniform(-0.1, 0.1, (todo.size, 7))
            q[todo] = np.clip(draw, self.lower, self.upper)
            todo = todo[~self.checker.are_valid(q[todo])]
            if todo.size == 0:
                break
        self.q[idx] = q
        self.target[idx] = self.np_random.uniform(TARGET_LOW, TARGET_HIGH, (idx.size, 3))
        self._tcp[idx] = self.tcp_position(q)

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every copy; re-derive the limits if the robot's version changed."""
        if self.robot.version != self.model_version:
            self._read_limits()
        obs, _ = super().reset(seed=seed, options=options)
        distance = np.linalg.norm(self._tcp - self.target, axis=1)
        return obs, {"distance": distance, "_distance": np.ones(self.num_envs, dtype=bool)}

    @one_thread_at_a_time
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy; copies that ended on the previous step are reset instead.

        Raises:
            StaleModelError: the robot's limits changed since the last reset.
        """
        if self.robot.version != self.model_version:
            raise StaleModelError(
                f"PandaReachVectorEnv: the limits of robot '{self.robot.name}' changed "
                f"(Robot.set_limits: version {self.model_version} -> {self.robot.version}); "
                "call reset() to run under the new limits",
                self.model_version,
                self.robot.version,
            )
        a = np.clip(action_array(actions, (self.num_envs, 7), "actions"), -1.0, 1.0)
        self.q = np.clip(self.q + self.dt * a * self.v_max, self.lower, self.upper)
        self._tcp = self.tcp_position(self.q)
        distance = np.linalg.norm(self._tcp - self.target, axis=1)
        reward = -distance - 0.01 * np.einsum("ij,ij->i", a, a)
        collision = ~self.checker.are_valid(self.q)
        reached = distance < self.tolerance
        reward = reward - 10.0 * collision + 10.0 * (reached & ~collision)
        info = {
            "distance": distance,
            "collision": collision,
            "success": reached & ~collision,
        }
        self.steps += 1
        terminated = collision | reached
        truncated = self.steps >= self.max_episode_steps
        ended = self.prev_done.copy()
        self._autoreset(reward, terminated, truncated)
        if np.any(ended):  # reset copies: their info describes the new initial state
            info["distance"][ended] = np.linalg.norm(self._tcp[ended] - self.target[ended], axis=1)
            info["collision"][ended] = False
            info["success"][ended] = False
        mask = np.ones(self.num_envs, dtype=bool)
        info.update({"_distance": mask, "_collision": mask, "_success": mask})
        return self._obs(), reward, terminated, truncated, info
