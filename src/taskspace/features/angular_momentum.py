"""Centroidal angular momentum (TSID's ``TaskAMEquality``; Orin, Goswami and Lee 2013).

Thread safety: the feature evaluates Pinocchio's centroidal maps on its own data under its
lock, so calls from several threads are serialized and each gets its own state's value;
otherwise as every feature (see :mod:`taskspace.features.feature`): do not change the robot
while another thread evaluates it.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class AngularMomentum(Feature):
    """The angular momentum about the center of mass, ``L = A_ang(q) v`` [kg m^2/s].

    ``A_ang`` is the angular part (last three rows) of the centroidal momentum matrix
    ``A_g`` (world axes, about the CoM); it is not the Jacobian of any function of ``q``
    (angular momentum is not integrable), so this feature has no value to reach: its
    residual is zero and its Jacobian is ``A_ang``. As a task:

    * acceleration level (inverse dynamics, operational space): the rows read ``A_ang a ~
      -A_ang_dot v - kd (L - L_ref) + L_dot_ref``, i.e. ``L_dot = -kd (L - L_ref)``: ``kd``
      [1/s] regulates the momentum to ``L_ref`` (``task.set_reference(velocity=L_ref,
      acceleration=L_dot_ref)``, zero by default); ``kp`` has no effect.
    * velocity level (IK): the rows ``A_ang dq ~ 0`` penalize the angular momentum the step
      would create (``dt L``).

    The target is always zero (size 3), set by ``Task(AngularMomentum(robot))``. Evaluated
    with Pinocchio's ``computeCentroidalMapTimeVariation`` on the feature's own data (one
    evaluation at a time: calls from several threads are serialized).

    Args:
        robot: the robot.
    """

    dim = 3

    def __init__(self, robot: Robot) -> None:
        super().__init__(robot, "angular_momentum")
        self._data = robot._model.createData()
        self._lock = threading.Lock()
        self._zero = np.zeros(3)
        self._zero.setflags(write=False)

    def default_target(self) -> FloatArray:
        """The only target: zero (size 3)."""
        return self._zero

    def check_target(self, target: Any) -> FloatArray:
        """Only zero (size 3); the momentum to track is a reference velocity."""
        t = as_vector(target, 3, f"target of feature '{self.name}'")
        if np.any(t != 0.0):
            raise InvalidInputError(
                "the angular momentum feature's target is zero; to track a momentum L_ref, "
                "call task.set_reference(velocity=L_ref) (and give the task a kd)"
            )
        return self._zero

    def value(self, state: State) -> FloatArray:
        """Zero: angular momentum is not a function of ``q`` (see :meth:`momentum`)."""
        self._check_state(state)
        return self._zero.copy()

    def momentum(self, state: State) -> FloatArray:
        """``L = A_ang v`` at the state (needs its velocity) [kg m^2/s]."""
        self._check_state(state)
        self._require_velocity(state)
        with self._lock:
            pin.computeCentroidalMomentum(self.robot._model, self._data, state.q, state.v)
            return np.asarray(self._data.hg.angular).copy()

    def jacobian(self, state: State) -> FloatArray:
        """``A_ang``: angular rows of the centroidal momentum matrix (3 x nv)."""
        self._check_state(state)
        with self._lock:
            Ag = pin.computeCentroidalMap(self.robot._model, self._data, state.q)
            return np.asarray(Ag[3:]).copy()

    def drift(self, state: State) -> FloatArray:
        """``A_ang_dot v``: the rate of change of ``L`` at zero joint acceleration."""
        self._check_state(state)
        self._require_velocity(state)
        with self._lock:
            pin.computeCentroidalMomentumTimeVariation(
                self.robot._model, self._data, state.q, state.v, np.zeros(self.robot.nv)
            )
            return np.asarray(self._data.dhg.angular).copy()

    def _require_velocity(self, state: State) -> None:
        if not state.has_velocity:
            raise InvalidInputError(
                f"feature '{self.name}' needs the velocity: make the state with robot.state(q, v)"
            )

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """Zero and ``A_ang``."""
        return np.zeros(3), self.jacobian(state)
