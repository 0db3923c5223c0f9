"""Linear state feedback on a robot about an equilibrium: ``tau = tau_eq + S^T (-K x)``.

``x = (q (-) q_eq, v - v_eq)`` in tangent coordinates (``pin.difference``), ``K`` e.g. an LQR
gain designed on :func:`taskspace.control.linearization.linearize`.

Thread safety: a :class:`StateFeedbackController` keeps only its system and gain, fixed after
construction (each call builds new arrays), so it may be called from several threads; do not
reassign ``system`` or ``K`` meanwhile.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_matrix, as_vector
from taskspace.control.linearization import LinearizedSystem
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot


class StateFeedbackController:
    """``controller(t, q, v)`` applying ``u = -K x`` on the actuated joints.

    Args:
        robot: the robot the system was linearized on.
        system: the linearization (equilibrium and actuated joints).
        K: gain (m x 2 nv), ``u = -K x``.
    """

    def __init__(self, robot: Robot, system: LinearizedSystem, K: Any) -> None:
        if not isinstance(system, LinearizedSystem):
            raise InvalidInputError(
                f"system must be the LinearizedSystem of linearize(robot, ...), got "
                f"{type(system).__name__}"
            )
        if system.robot_name is not None and system.robot_name != robot.name:
            # (a ur5's linearization drove a ur10 of the same nq silently)
            raise InvalidInputError(
                f"system was linearized on '{system.robot_name}', not on '{robot.name}': "
                "linearize this robot (its gains K were designed for the other one)"
            )
        if system.q_eq.shape != (robot.nq,):
            raise InvalidInputError(
                f"system was linearized on a robot with nq = {system.q_eq.shape[0]}, not on "
                f"'{robot.name}' (nq = {robot.nq})"
            )
        self.robot = robot
        self.system = system
        m = system.actuated.size
        self.K = as_matrix(K, (m, 2 * robot.nv), "K")
        self._model = robot._model
        self._nv = robot.nv

    def state_error(self, q: FloatArray, v: FloatArray) -> FloatArray:
        """``x = (q (-) q_eq, v - v_eq)`` (2 nv).

        Raises:
            ShapeError, NotFiniteError: ``q`` or ``v`` of the wrong size or not finite (a
                wrong size was a bare Pinocchio error, NaN gave NaN torques).
        """
        q = as_vector(q, self.robot.nq, "q")
        v = as_vector(v, self._nv, "v")
        dq = pin.difference(self._model, self.system.q_eq, q)
        return np.concatenate([dq, v - self.system.v_eq])

    def __call__(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        """Torques [N m]: ``tau_eq`` plus ``-K x`` on the actuated joints."""
        tau = self.system.tau_eq.copy()
        tau[self.system.actuated] += -self.K @ self.state_error(q, v)
        return tau
