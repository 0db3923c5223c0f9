"""Robot dynamics: forward simulation (ABA + integrators), energies, Newton-Euler uses.

Slides 5:18-5:29 of the lecture notes.
"""

from taskspace.dynamics.energy import kinetic_energy, mechanical_energy, potential_energy
from taskspace.dynamics.forward_dynamics import ForwardDynamics, JointFriction, forward_dynamics
from taskspace.dynamics.integrators import (
    Integrator,
    IntegratorStep,
    TorqueFunction,
    rk4_step,
    semi_implicit_euler_step,
)
from taskspace.dynamics.newton_euler import (
    coriolis_torque,
    gravity_torque,
    inverse_dynamics,
    mass_matrix,
    nonlinear_effects,
)
from taskspace.dynamics.pendulum import pendulum_acceleration, pendulum_energy, pendulum_torque
from taskspace.dynamics.simulation import (
    Controller,
    SimulationOptions,
    SimulationStatus,
    SimulationTrajectory,
    simulate,
)

__all__ = [
    "Controller",
    "ForwardDynamics",
    "Integrator",
    "IntegratorStep",
    "JointFriction",
    "SimulationOptions",
    "SimulationStatus",
    "SimulationTrajectory",
    "TorqueFunction",
    "coriolis_torque",
    "forward_dynamics",
    "gravity_torque",
    "inverse_dynamics",
    "kinetic_energy",
    "mass_matrix",
    "mechanical_energy",
    "nonlinear_effects",
    "pendulum_acceleration",
    "pendulum_energy",
    "pendulum_torque",
    "potential_energy",
    "rk4_step",
    "semi_implicit_euler_step",
    "simulate",
]
