"""Learning in robotics: datasets, MDPs, policy search, movement primitives.

Chapter 10 of the lecture notes (tabular RL, policy search, movement primitives); IK datasets
in :mod:`taskspace.learning.ik_dataset`. Dynamic programming and the HJB equation (the
model-based side) live in :mod:`taskspace.optimal_control`.
"""

from taskspace.learning.tabular import (
    MDPSimulator,
    TabularOptions,
    TabularResult,
    q_learning,
    sarsa,
    td_lambda,
)

__all__ = [
    "MDPSimulator",
    "TabularOptions",
    "TabularResult",
    "q_learning",
    "sarsa",
    "td_lambda",
]
