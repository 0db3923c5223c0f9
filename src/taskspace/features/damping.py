"""The step itself as a task variable: a damping task (pink's ``DampingTask``).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Damping(Feature):
    """A zero residual with Jacobian ``I``: as a task, the cost ``rho |dq|^2``.

    In a weighted velocity-level stack the task's rows are ``sqrt(rho) I dq ~ 0``, which adds
    ``rho |dq|^2`` to the objective (a per-task damping, where the IK solver's ``damping``
    option is one value for the whole stack); ``weight`` may be one value per tangent
    direction (size nv) to damp some joints more. At the acceleration level the rows read
    ``sqrt(rho) a ~ -sqrt(rho) kd v``: with ``kp = kd = 0`` the cost ``rho |a|^2``.

    The target is always zero (size nv); ``Task(Damping(robot), weight=...)`` sets it.

    Args:
        robot: the robot.
    """

    def __init__(self, robot: Robot) -> None:
        super().__init__(robot, "damping")
        self.dim = robot.nv
        self._identity = np.eye(robot.nv)
        self._identity.setflags(write=False)
        self._zero = np.zeros(robot.nv)
        self._zero.setflags(write=False)

    def default_target(self) -> FloatArray:
        """The only target: zero (size nv)."""
        return self._zero

    def check_target(self, target: Any) -> FloatArray:
        """Only zero (size nv) is a target of the damping feature."""
        t = as_vector(target, self.dim, f"target of feature '{self.name}'")
        if np.any(t != 0.0):
            raise InvalidInputError(
                "the damping feature's target is zero (its residual is the step itself); "
                "for a posture to reach, use JointConfiguration"
            )
        return self._zero

    def value(self, state: State) -> FloatArray:
        """Zero (size nv): the feature measures the step, not the configuration."""
        self._check_state(state)
        return self._zero.copy()

    def jacobian(self, state: State) -> FloatArray:
        """Identity (nv x nv)."""
        self._check_state(state)
        return self._identity

    def drift(self, state: State) -> FloatArray:
        """Zero."""
        self._check_state(state)
        return np.zeros(self.dim)

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """Zero and the identity."""
        self._check_state(state)
        return np.zeros(self.dim), self._identity
