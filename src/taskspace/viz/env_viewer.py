"""Meshcat rendering of taskspace's Gymnasium environments: the :class:`MeshcatRender` wrapper.

The environments of :mod:`taskspace.learning.envs` draw with matplotlib (``taskspace.learning``
may not import ``taskspace.viz``). Wrapped in :class:`MeshcatRender`, any of them whose
unwrapped environment exposes ``robot`` (a :class:`~taskspace.model.Robot`) and ``q`` (its
configuration) is shown with the meshcat :class:`~taskspace.viz.Viewer` instead:

* ``render_mode="human"``: a live meshcat server (open :attr:`MeshcatRender.url` in a
  browser), updated after every ``reset`` and ``step``;
* ``render_mode="rgb_array"``: :meth:`MeshcatRender.render` returns the scene as an
  ``H x W x 3`` ``uint8`` image, a headless-Chromium snapshot (:meth:`Viewer.snapshot`: about
  a second per image; for recording an episode, not for training).

A 3-vector ``target`` attribute of the environment (the Panda reach goal) is drawn as a target
marker.

Example:
    >>> env = MeshcatRender(gym.make("taskspace/PandaReach-v0"), "human")  # doctest: +SKIP
    >>> print(env.url); env.reset(seed=0)                                   # doctest: +SKIP

Thread safety: a :class:`MeshcatRender` is one per thread, like the environment it wraps
(taskspace's environments raise :class:`~taskspace.errors.ConcurrentUseError` when a second thread
steps them) and the :class:`Viewer` it draws into.
"""

from __future__ import annotations

import io
from typing import Any

import gymnasium as gym
import numpy as np

from taskspace.errors import InvalidInputError
from taskspace.viz.viewer import Viewer

RENDER_MODES = ("human", "rgb_array")


class MeshcatRender(gym.Wrapper):  # type: ignore[type-arg]
    """Show a taskspace environment's robot in meshcat after every reset and step.

    Args:
        env: the environment (its own ``render_mode`` is not used; create it with ``None``).
        render_mode: ``"human"`` (live viewer) or ``"rgb_array"`` (snapshots).
        viewer: a :class:`Viewer` of the environment's robot to draw into (default: a new one,
            live for ``"human"``).
        size: ``(width, height)`` of the ``"rgb_array"`` images [pixels].

    Raises:
        InvalidInputError: an unknown render mode, or an environment without ``robot`` and
            ``q``.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        render_mode: str = "human",
        *,
        viewer: Viewer | None = None,
        size: tuple[int, int] = (480, 480),
    ) -> None:
        super().__init__(env)
        if render_mode not in RENDER_MODES:
            valid = ", ".join(repr(m) for m in RENDER_MODES)
            raise InvalidInputError(f"render_mode {render_mode!r} is not supported; use {valid}")
        base: Any = env.unwrapped
        if not hasattr(base, "robot") or not hasattr(base, "q"):
            raise InvalidInputError(
                f"{type(base).__name__} has no 'robot' and 'q' attributes: MeshcatRender shows "
                "taskspace environments (taskspace.learning.envs)"
            )
        self._mode = render_mode
        self.size = (int(size[0]), int(size[1]))
        self.viewer = (
            viewer if viewer is not None else Viewer(base.robot, live=render_mode == "human")
        )
        self.metadata = {**env.metadata, "render_modes": list(RENDER_MODES)}

    @property
    def render_mode(self) -> str:  # type: ignore[override]
        """``"human"`` or ``"rgb_array"``."""
        return self._mode

    @property
    def url(self) -> str:
        """URL of the live viewer (``"human"`` mode)."""
        return self.viewer.url

    def _show(self) -> None:
        base: Any = self.env.unwrapped
        self.viewer.display(np.asarray(base.q, dtype=float))
        target = getattr(base, "target", None)
        if target is not None and np.shape(target) == (3,):
            self.viewer.add_target("target", np.asarray(target, dtype=float), scale=0.08)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Reset the environment and show its initial state."""
        out = self.env.reset(**kwargs)
        self._show()
        return out

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        """Step the environment and show its new state."""
        out = self.env.step(action)
        self._show()
        return out

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """The scene as an image (``"rgb_array"``); ``None`` for ``"human"`` (already shown)."""
        if self._mode == "human":
            return None
        from PIL import Image

        png = self.viewer.snapshot(size=self.size)
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).copy()

    def close(self) -> None:
        """Stop the live viewer's server (if this wrapper is live) and close the environment."""
        self.viewer.close()
        super().close()
