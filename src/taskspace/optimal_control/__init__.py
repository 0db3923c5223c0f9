"""Optimal control: dynamic programming on MDPs and grids, and the HJB equation.

Chapter 8 of the lecture notes (Bellman's principle, the HJB equation, the infinite-horizon
case): value and policy iteration on finite MDPs with sparse transition matrices, and fitted
value iteration on a state grid (multilinear interpolation) for continuous systems.
"""

from taskspace.optimal_control.dynamic_programming import (
    DPResult,
    DPStatus,
    FiniteHorizonResult,
    ValueIterationOptions,
    evaluate_policy,
    finite_horizon_value_iteration,
    greedy_policy,
    policy_iteration,
    value_iteration,
)
from taskspace.optimal_control.fitted_value_iteration import (
    FittedValueIterationOptions,
    FittedValueIterationResult,
    fitted_value_iteration,
    rk4_step,
)
from taskspace.optimal_control.grid import StateGrid, geometric_axis, make_grid
from taskspace.optimal_control.mdp import MDP, deterministic_mdp, grid_world, make_mdp, t_maze
from taskspace.optimal_control.problems import (
    CartPoleBalance,
    DoubleIntegrator,
    PendulumSwingUp,
    cartpole_acceleration,
    min_time,
    min_time_switching_curve,
    wrap_angle,
)

__all__ = [
    "MDP",
    "CartPoleBalance",
    "DPResult",
    "DPStatus",
    "DoubleIntegrator",
    "FiniteHorizonResult",
    "FittedValueIterationOptions",
    "FittedValueIterationResult",
    "PendulumSwingUp",
    "StateGrid",
    "ValueIterationOptions",
    "cartpole_acceleration",
    "deterministic_mdp",
    "evaluate_policy",
    "finite_horizon_value_iteration",
    "fitted_value_iteration",
    "geometric_axis",
    "greedy_policy",
    "grid_world",
    "make_grid",
    "make_mdp",
    "min_time",
    "min_time_switching_curve",
    "policy_iteration",
    "rk4_step",
    "t_maze",
    "value_iteration",
    "wrap_angle",
]
