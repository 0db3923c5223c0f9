"""Base classes of the Gymnasium environments on registry robots (single and batched).

:class:`RobotEnv` holds what the single environments share: the robot and its Pinocchio data,
the ABA + semi-implicit Euler substeps, the render mode and the rendering. Rendering draws the
state with matplotlib: ``"rgb_array"`` returns an ``H x W x 3`` ``uint8`` image (an off-screen
Agg canvas, no display needed); ``"human"`` draws into a pyplot window after every step and
reset (with a non-interactive backend such as Agg nothing is shown). Subclasses implement
``_draw(ax)``. For the robot in 3-D, wrap any environment of this package in
:class:`taskspace.viz.env_viewer.MeshcatRender` (meshcat: a live viewer or snapshots).

:class:`RobotVectorEnv` holds what the batched environments share: the batched spaces, the
step counters and the next-step auto-reset of ``gymnasium.vector`` (a copy that ended on the
previous step is reset instead of stepped, with reward 0).

Thread safety: an environment is a simulation state (``q``, ``v``, Pinocchio data, step
counters, RNG) and is not thread-safe, as Gymnasium environments are not: use one environment
per thread (or a batched environment). Sharing is detected: ``reset``, ``step`` and
``render`` of every environment of :mod:`taskspace.learning.envs` raise
:class:`~taskspace.errors.ConcurrentUseError` when another thread is inside one of them on the
same environment (instead of interleaving two threads' steps into one trajectory).
"""

from __future__ import annotations

import functools
import inspect
import threading
from collections.abc import Callable
from typing import Any, TypeVar

import gymnasium as gym
import numpy as np
import pinocchio as pin
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from taskspace._validation import as_float_array, check_count, require_extra
from taskspace.errors import ConcurrentUseError, InvalidInputError, NotFiniteError, ShapeError
from taskspace.model.robot import Robot

F = TypeVar("F", bound=Callable[..., Any])

_GUARD_CREATION = threading.Lock()


def _guard(env: Any) -> Any:
    """The object's re-entrant guard (made on first use, once even when threads race)."""
    guard = env.__dict__.get("_one_thread_guard")
    if guard is None:
        with _GUARD_CREATION:
            guard = env.__dict__.setdefault("_one_thread_guard", threading.RLock())
    return guard


def one_thread_at_a_time(method: F) -> F:
    """Raise :class:`ConcurrentUseError` when another thread is inside a guarded method.

    The guard is a per-object re-entrant lock taken without blocking: the same thread may
    nest guarded calls (``step`` rendering in ``"human"`` mode), a second thread gets the
    error instead of a step interleaved with the first one's. ``step(self, action)`` and
    ``step(self, actions)`` get a wrapper with that exact signature (the hot path: no
    argument packing, ~0.2 us per call instead of ~0.5 us).
    """
    name = method.__name__
    params = list(inspect.signature(method).parameters)

    def busy(self: Any) -> ConcurrentUseError:
        return ConcurrentUseError(f"{type(self).__name__}.{name}")

    if params == ["self", "action"]:

        def guarded_action(self: Any, action: Any) -> Any:
            guard = self.__dict__.get("_one_thread_guard") or _guard(self)
            if not guard.acquire(False):
                raise busy(self)
            try:
                return method(self, action)
            finally:
                guard.release()

        guarded: Callable[..., Any] = guarded_action
    elif params == ["self", "actions"]:

        def guarded_actions(self: Any, actions: Any) -> Any:
            guard = self.__dict__.get("_one_thread_guard") or _guard(self)
            if not guard.acquire(False):
                raise busy(self)
            try:
                return method(self, actions)
            finally:
                guard.release()

        guarded = guarded_actions
    else:

        def guarded_any(self: Any, *args: Any, **kwargs: Any) -> Any:
            guard = self.__dict__.get("_one_thread_guard") or _guard(self)
            if not guard.acquire(False):
                raise busy(self)
            try:
                return method(self, *args, **kwargs)
            finally:
                guard.release()

        guarded = guarded_any
    functools.update_wrapper(guarded, method)
    return guarded  # type: ignore[return-value]


RENDER_MODES = ("rgb_array", "human")
IMAGE_SIZE = 400
"""Side of the rendered square images [pixels]."""


def check_render_mode(render_mode: str | None, modes: tuple[str, ...]) -> str | None:
    """``render_mode`` if it is ``None`` or one of ``modes``, else an error listing them."""
    if render_mode is not None and render_mode not in modes:
        valid = ", ".join(repr(m) for m in (None, *modes))
        raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use {valid}")
    if render_mode is not None:
        require_extra("viz", f"render_mode={render_mode!r} (drawn with matplotlib)")
    return render_mode


def snap_roundoff(values: Any) -> tuple[float, ...]:
    """Entries below ``1e-12`` times the largest (round-off of ``cos(pi/2)``...) set to 0."""
    vals = tuple(float(x) for x in values)
    scale = max(abs(x) for x in vals)
    return tuple(0.0 if abs(x) <= 1e-12 * scale else x for x in vals)


class RobotEnv(gym.Env[np.ndarray, Any]):
    """A single environment on a registry robot, stepped with Pinocchio's ABA.

    Args:
        robot_name: registry name (``Robot.load``).
        dt: control period [s]; substeps: ABA + semi-implicit Euler steps per period.
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 20}  # noqa: RUF012

    def __init__(self, robot_name: str, dt: float, substeps: int, render_mode: str | None) -> None:
        self.render_mode = check_render_mode(render_mode, RENDER_MODES)
        self.robot = Robot.load(robot_name)
        self._model = self.robot._model  # the robot's own: never handed out (see ``model``)
        self.data = self._model.createData()
        self.dt = float(dt)
        self.substeps = int(substeps)
        self._figure: Any = None
        self._window: Any = None

    @property
    def model(self) -> pin.Model:
        """``robot.model``: the robot's read-only copy (edit it with ``robot.edit_model()``)."""
        return self.robot.model

    def _integrate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, max_speed: float = np.inf
    ) -> tuple[np.ndarray, np.ndarray]:
        """``substeps`` steps ``v += h ABA(q, v, tau)`` (clipped to ``max_speed``), ``q += h v``."""
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            a = pin.aba(self._model, self.data, q, v, tau)
            v = v + h * a
            if max_speed < np.inf:
                v = np.minimum(np.maximum(v, -max_speed), max_speed)  # np.clip: 10x slower
            q = q + h * v
        return q, v

    def _draw(self, ax: Any) -> None:
        """Draw the current state on a matplotlib ``Axes``."""
        raise NotImplementedError

    @one_thread_at_a_time
    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """Render the current state.

        Returns:
            An ``IMAGE_SIZE x IMAGE_SIZE x 3`` ``uint8`` image for ``"rgb_array"``; ``None``
            for ``"human"`` (drawn into the window) and without a render mode.
        """
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode=...")
            return None
        if self.render_mode == "rgb_array":
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            if self._figure is None:
                self._figure = Figure(figsize=(4, 4), dpi=IMAGE_SIZE / 4)
                FigureCanvasAgg(self._figure)
            fig = self._figure
            fig.clear()
            self._draw(fig.add_axes((0.0, 0.0, 1.0, 1.0)))
            fig.canvas.draw()
            return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()  # type: ignore[attr-defined]
        import matplotlib.pyplot as plt

        if self._window is None or not plt.fignum_exists(self._window.number):
            self._window = plt.figure(figsize=(4, 4))
        self._window.clear()
        self._draw(self._window.add_axes((0.0, 0.0, 1.0, 1.0)))
        if plt.get_backend().lower() != "agg":
            plt.pause(1.0 / float(self.metadata["render_fps"]))
        return None

    def _after_step(self) -> None:
        if self.render_mode == "human":
            self.render()

    def close(self) -> None:
        """Close the rendering window."""
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window)
            self._window = None
        self._figure = None


MAX_NUM_ENVS = 1_000_000
"""Most copies of a batched environment (their state arrays are allocated at once)."""


def action_array(action: Any, shape: tuple[int, ...], name: str = "action") -> np.ndarray:
    """``action`` as a float array of ``shape``.

    Text, complex values, a wrong size or NaN raise (``inf`` is clipped to the action bounds
    by the environments, like any large value).
    """
    arr = as_float_array(action, name)
    if arr.size != int(np.prod(shape)):
        raise ShapeError(name, shape, arr.shape)
    arr = arr.reshape(shape)
    nan = np.isnan(arr.ravel())
    if nan.any():
        raise NotFiniteError(name, np.flatnonzero(nan).tolist())
    return arr


class RobotVectorEnv(VectorEnv):
    """N copies stepped together with numpy, next-step auto-reset (no rendering).

    Subclasses set ``single_action_space`` / ``single_observation_space`` through
    :meth:`_set_spaces` and implement ``_reset_copies(mask)``.
    """

    metadata = {"render_modes": [], "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}  # noqa: RUF012

    def __init__(
        self, num_envs: int, dt: float, substeps: int, max_episode_steps: int, render_mode: Any
    ) -> None:
        if render_mode is not None:
            raise InvalidInputError(
                f"render_mode {render_mode!r} is not supported by the batched environments; "
                "use None (render a single environment instead)"
            )
        num_envs = check_count(num_envs, "num_envs", minimum=1)
        if num_envs > MAX_NUM_ENVS:
            raise InvalidInputError(f"num_envs must be at most {MAX_NUM_ENVS}, got {num_envs}")
        self.num_envs = num_envs
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.max_episode_steps = int(max_episode_steps)
        self.render_mode = render_mode
        self.steps = np.zeros(self.num_envs, dtype=np.int64)
        self.prev_done = np.zeros(self.num_envs, dtype=bool)

    def _set_spaces(self, action: spaces.Space[Any], observation: spaces.Space[Any]) -> None:
        self.single_action_space = action
        self.single_observation_space = observation
        self.action_space = batch_space(action, self.num_envs)
        self.observation_space = batch_space(observation, self.num_envs)

    def _reset_copies(self, mask: np.ndarray) -> None:
        """Draw new initial states for the copies in ``mask``."""
        raise NotImplementedError

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every copy."""
        super().reset(seed=seed)
        self._reset_copies(np.ones(self.num_envs, dtype=bool))
        self.steps[:] = 0
        self.prev_done[:] = False
        return self._obs(), {}

    def _obs(self) -> np.ndarray:
        raise NotImplementedError

    def _autoreset(self, reward: np.ndarray, terminated: np.ndarray, truncated: np.ndarray) -> None:
        """Count the step, truncate, and reset the copies that ended on the previous step."""
        done = self.prev_done
        if np.any(done):
            self._reset_copies(done)
            self.steps[done] = 0
            reward[done] = 0.0
            terminated[done] = False
            truncated[done] = False
        self.prev_done = terminated | truncated
