"""Joint position, velocity and acceleration limits as box bounds on the step.

Thread safety: a constraint keeps no per-step workspace besides immutable caches replaced at
once (e.g. the velocity box for the last ``dt``), and reads the :class:`~taskspace.model.State`
it is given, so one constraint may serve solvers in several threads. What it derives from the
robot (limits, collision pairs, compiled rows) is rebuilt on the next call after a model or
world change; do not change the robot, the world or the constraint's parameters (bounds, gains,
margins) while another thread steps with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray, as_vector, check_positive
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.features.rows import INF, Box
from taskspace.model.versioning import ModelFollower

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


def _as_slice(indices: np.ndarray) -> slice | None:
    """The slice equal to ``indices`` when they are consecutive, else ``None``."""
    if indices.size and np.all(np.diff(indices) == 1):
        return slice(int(indices[0]), int(indices[-1]) + 1)
    return None


def _positive_limits(limits: Any, size: int) -> FloatArray:
    """``limits`` as a float vector of ``size`` entries in ``(0, inf]`` (inf: unlimited)."""
    raw = np.asarray(limits) if not isinstance(limits, np.ndarray) else limits
    if raw.dtype.kind not in "biuf":
        raise InvalidInputError(
            f"velocity limits must be real numbers (inf where unlimited), got dtype {raw.dtype}"
        )
    lim = raw.astype(np.float64)
    if lim.shape != (size,):
        raise ShapeError("limits", (size,), lim.shape)
    bad = np.flatnonzero(~(lim > 0))
    if bad.size:
        raise InvalidInputError(
            f"velocity limits must be > 0 (inf where unlimited); entries {bad.tolist()} are "
            f"{lim[bad].tolist()}"
        )
    return lim


class JointPositionLimits(Constraint):
    """``q_low + m <= q + dq <= q_high - m`` on every 1-DoF joint with finite limits.

    A configuration outside its limits gives a box that points back inside (it is pulled
    back, never rejected); velocity limits then bound how fast.

    Args:
        robot: the robot.
        margin: distance ``m`` kept from the limits [rad or m].

    The limits follow the robot: after :meth:`Robot.set_limits` the next :meth:`bounds` uses
    the new ones (:class:`~taskspace.model.versioning.ModelFollower`).
    """

    def __init__(self, robot: Robot, margin: float = 0.0) -> None:
        super().__init__(robot, "joint position limits")
        self._margin = check_positive(margin, "margin", strict=False)
        self._follower = ModelFollower(robot, "JointPositionLimits", self._derive)

    @property
    def margin(self) -> float:
        """Distance ``m`` kept from the limits [rad or m] (fixed at construction)."""
        return self._margin

    @margin.setter
    def margin(self, value: object) -> None:
        # the limits are derived from it (and the compiled IK stack keeps a copy): an
        # assignment was silently ignored until the robot's limits changed
        raise InvalidInputError(
            "JointPositionLimits.margin is fixed at construction; create a new "
            f"JointPositionLimits(robot, margin={value!r})"
        )

    def _derive(self) -> None:
        """Copy the robot's limits (again after :meth:`Robot.set_limits`)."""
        robot = self.robot
        iq = robot.limited_joints_q
        iv = robot.limited_joints_v
        low = robot.lower_limits[iq] + self._margin
        high = robot.upper_limits[iq] - self._margin
        if np.any(low > high):
            raise InvalidInputError(
                f"margin {self.margin} is larger than half a joint range of robot '{robot.name}'"
            )
        nv = robot.nv
        self._iq, self._iv, self._low, self._high = iq, iv, low, high
        self._lb_template = np.full(nv, -INF)
        self._ub_template = np.full(nv, INF)
        self._q_slice = _as_slice(iq)
        self._v_slice = _as_slice(iv)
        # every joint 1-DoF and limited (fixed-base arms): plain vector operations
        self._all = (
            robot.nq == robot.nv and len(iq) == robot.nv and bool(np.all(iq == np.arange(nv)))
        )

    def bounds(self, state: State, dt: float) -> Box:
        """Box on ``dq`` (for the robot's current limits)."""
        self._follower.sync()
        if self._all:
            q = state.q
            return Box(self._low - q, self._high - q)
        lb = self._lb_template.copy()
        ub = self._ub_template.copy()
        q = state.q[self._q_slice] if self._q_slice is not None else state.q[self._iq]
        if self._v_slice is not None:
            lb[self._v_slice] = self._low - q
            ub[self._v_slice] = self._high - q
        else:
            lb[self._iv] = self._low - q
            ub[self._iv] = self._high - q
        return Box(lb, ub)

    def kernel_arguments(self) -> tuple[list[int], list[int], FloatArray, FloatArray, bool]:
        """``(iq, iv, low, high, hard)``: what a compiled kernel needs to evaluate :meth:`bounds`.

        ``lb[iv] = low - q[iq]``, ``ub[iv] = high - q[iq]``, unbounded elsewhere [rad or m].
        A kernel that keeps them must call this again when :attr:`model_version` changes.
        """
        self._follower.sync()
        return (
            [int(i) for i in self._iq],
            [int(i) for i in self._iv],
            self._low,
            self._high,
            bool(self.hard_bounds),
        )

    @property
    def model_version(self) -> int:
        """The robot version the limits are copied from (current after :meth:`bounds`)."""
        self._follower.sync()
        return self._follower.version


class JointVelocityLimits(Constraint):
    """``|dq| <= v_max dt``.

    On a floating-base robot the first six entries of ``dq`` are the base's twist in its own
    frame (linear [m], then angular [rad], Pinocchio's free-flyer tangent), unlimited by
    default; ``base_limits`` bounds them.

    Args:
        robot: the robot.
        limits: per-joint velocity limits (size nv) [rad/s or m/s], ``inf`` where
            unlimited; default ``robot.velocity_limits`` (the floating base is unlimited).
        scale: factor applied to the limits.
        base_limits: bound on the floating base's twist (size 6: linear [m/s] then angular
            [rad/s], in the base frame; ``inf`` where unlimited); replaces the first six
            entries of ``limits`` (a floating-base robot only).

    Without ``limits`` the robot's velocity limits are followed: after
    :meth:`Robot.set_limits` the next :meth:`bounds` uses the new ones.
    """

    hard_bounds = True
    bounds_read_state = False  # the box depends only on dt and the robot's version

    def __init__(
        self,
        robot: Robot,
        limits: Any = None,
        scale: float = 1.0,
        *,
        base_limits: Any = None,
    ) -> None:
        super().__init__(robot, "joint velocity limits")
        self._given = None if limits is None else _positive_limits(limits, robot.nv)
        self._base = None
        if base_limits is not None:
            if not robot.is_floating:
                raise InvalidInputError(
                    f"base_limits: robot '{robot.name}' has no floating base; bound its joints "
                    "with limits"
                )
            self._base = _positive_limits(base_limits, 6)
        self._scale = check_positive(scale, "scale")
        self._follower = ModelFollower(robot, "JointVelocityLimits", self._derive)

    def _derive(self) -> None:
        """The limits: the given ones, or the robot's current ones (again after set_limits)."""
        lim = self.robot.velocity_limits if self._given is None else self._given
        if self._base is not None:
            lim = lim.copy()
            lim[:6] = self._base
        self._limits = lim * self._scale
        self._box_for_dt: tuple[float, Box] = (-1.0, Box(self._limits, self._limits))

    @property
    def limits(self) -> FloatArray:
        """Velocity limits applied (size nv, scaled) [rad/s or m/s].

        The robot's current ones unless ``limits`` were given.
        """
        self._follower.sync()
        return self._limits

    def bounds(self, state: State, dt: float) -> Box:
        """Box on ``dq`` (cached per ``dt``; do not modify the returned arrays)."""
        # (dt, box) is one attribute, read and replaced at once: a constraint shared by two
        # solvers stepping with different dt in two threads never returns the other's box.
        synced = self._follower.sync()
        cached_dt, box = self._box_for_dt
        if synced or dt != cached_dt:
            step = np.minimum(self._limits * dt, INF)
            box = Box(-step, step)
            self._box_for_dt = (dt, box)
        return box


class JointAccelerationLimits(Constraint):
    """``|dq / dt - v| <= a_max dt`` with ``v`` the state's velocity.

    Args:
        robot: the robot.
        limits: per-joint acceleration limits (size nv) [rad/s^2 or m/s^2].
    """

    hard_bounds = True

    def __init__(self, robot: Robot, limits: Any) -> None:
        super().__init__(robot, "joint acceleration limits")
        self.limits = limits  # checked by __setattr__ (also when changed later)

    def __setattr__(self, name: str, value: object) -> None:
        """Check ``limits`` (size nv, > 0) on every assignment."""
        if name == "limits":
            value = as_vector(value, self.robot.nv, "limits")
            if np.any(value <= 0):
                raise InvalidInputError("acceleration limits must be > 0")
        super().__setattr__(name, value)

    def bounds(self, state: State, dt: float) -> Box:
        """Box on ``dq`` around ``v dt``."""
        center = state.v * dt
        half = self.limits * dt * dt
        return Box(center - half, center + half)
