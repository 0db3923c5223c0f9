"""How objects built from a robot follow its model version (:attr:`Robot.version`).

A robot's limits change only through :meth:`Robot.set_limits` (its other model values through
:meth:`Robot.edit_model`), which gives the robot a new version, never reused. An object that
copies anything derived from the limits (a constraint's box, a planning space's bounds, an
optimization problem's limit rows, a compiled kernel's copy) holds a :class:`ModelFollower` and
calls :meth:`ModelFollower.sync` before it uses its copy. While the robot keeps the version the
copy was made for, ``sync`` costs one integer comparison; when it differs, ``sync`` either
re-derives the copy (the owner gave a ``derive`` function) or raises
:class:`~taskspace.errors.StaleModelError` naming the owner (no ``derive``: objects whose shape
depends on the limits, such as a path problem's rows). Never a count, a hash or a comparison of
the arrays: the version is the only signal, so a change that keeps sizes and values elsewhere
(narrowing one joint) is seen as well.

Example::

    class MyBox:
        def __init__(self, robot):
            self.robot = robot
            self._model = ModelFollower(robot, "MyBox", self._derive)  # derives now

        def _derive(self):
            self._low = self.robot.lower_limits.copy()

        def bounds(self, q):
            self._model.sync()  # re-derives after robot.set_limits(...)
            return self._low - q
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from taskspace.errors import StaleModelError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot

__all__ = ["ModelFollower"]


class ModelFollower:
    """The robot version an owner's derived data was made for, and how to renew it.

    Args:
        robot: the robot the owner copies limits from.
        owner: what the owner is, for error messages (``"JointPositionLimits"``).
        derive: recomputes the owner's copy from the robot's current model; called once
            now and again by :meth:`sync` after each version change. ``None``: the owner
            cannot be renewed in place and :meth:`sync` raises instead.
        what_to_do: how to recover, appended to the :class:`StaleModelError` message of an
            owner without ``derive`` (default: build a new one).

    Attributes:
        version: the robot version the owner's copy was made for.

    Thread safety: ``sync`` may run ``derive`` in the calling thread; owners that are
    shared by threads serialize their calls as they already must.
    """

    __slots__ = ("_derive", "_what_to_do", "owner", "robot", "version")

    def __init__(
        self,
        robot: Robot,
        owner: str,
        derive: Callable[[], None] | None = None,
        *,
        what_to_do: str | None = None,
    ) -> None:
        self.robot = robot
        self.owner = owner
        self._derive = derive
        self._what_to_do = what_to_do
        version = robot.version
        if derive is not None:
            derive()
        self.version = version

    @property
    def stale(self) -> bool:
        """Whether the robot's version changed since the owner's copy was made."""
        return self.robot.version != self.version

    def sync(self) -> bool:
        """Bring the owner up to date with the robot's model.

        Returns:
            True when the copy was re-derived (the version had changed), False when it was
            current (one integer comparison).

        Raises:
            StaleModelError: the version changed and the owner cannot re-derive.
            TaskspaceError: ``derive`` refused the new limits (e.g. a margin larger than a
                new joint range); the owner stays stale and the next call tries again.
        """
        if self.robot._version == self.version:  # the hot path: one comparison
            return False
        return self._renew()

    def _renew(self) -> bool:
        robot = self.robot
        version = robot.version
        if self._derive is None:
            raise StaleModelError(
                f"{self.owner} was built for version {self.version} of robot '{robot.name}', "
                "whose model has changed since (Robot.set_limits or Robot.edit_model, now "
                f"version {version}); " + (self._what_to_do or f"build a new {self.owner}"),
                self.version,
                version,
            )
        self._derive()
        self.version = version
        return True

    def __repr__(self) -> str:
        state = "stale" if self.stale else "current"
        return f"ModelFollower({self.owner!r}, version={self.version}, {state})"
