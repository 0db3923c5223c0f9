"""Mechanical energy of a robot (slide 5:25: "use energy conservation to measure dynamics").

``T = 1/2 v^T M(q) v`` (``pin.computeKineticEnergy``) and ``U = -sum_i m_i g^T c_i(q)``
(``pin.computePotentialEnergy``, zero at height 0).

Thread safety: the functions build their own Pinocchio data (or none) per call and may run from
several threads.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pinocchio as pin

from taskspace.dynamics.newton_euler import finite_result

if TYPE_CHECKING:
    from taskspace.model.robot import Robot


def kinetic_energy(robot: Robot, q: Any, v: Any) -> float:
    """Kinetic energy ``T = 1/2 v^T M(q) v`` [J].

    Args:
        robot: the robot.
        q: configuration (nq).
        v: velocity (nv) [rad/s, m/s].

    Raises:
        InvalidInputError: ``T`` overflows float64 (``v = 1e300``; NaN before).
    """
    qa = robot.check_configuration(q)
    va = robot.check_velocity(v)
    T = float(pin.computeKineticEnergy(robot._model, robot._model.createData(), qa, va))
    return float(finite_result(T, "kinetic energy", v=va))


def potential_energy(robot: Robot, q: Any) -> float:
    """Gravitational potential energy ``U = -sum_i m_i g^T c_i(q)`` [J] (zero at height 0)."""
    qa = robot.check_configuration(q)
    return float(pin.computePotentialEnergy(robot._model, robot._model.createData(), qa))


def mechanical_energy(robot: Robot, q: Any, v: Any) -> float:
    """Total mechanical energy ``T + U`` [J]."""
    return kinetic_energy(robot, q, v) + potential_energy(robot, q)
