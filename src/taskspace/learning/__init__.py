"""Learning in robotics: datasets, MDPs, policy search, movement primitives.

Chapter 10 of the lecture notes (tabular RL, policy search, movement primitives); IK datasets
in :mod:`taskspace.learning.ik_dataset`. Dynamic programming and the HJB equation (the
model-based side) live in :mod:`taskspace.optimal_control`.
"""

from taskspace.learning.policies import LinearPolicy, Policy, RBFPolicy
from taskspace.learning.policy_search import (
    PolicySearchOptions,
    PolicySearchResult,
    PolicySearchStatus,
    cma_es,
    enac,
    enac_gradient,
    enac_regression,
    mu_lambda_es,
    pi2,
    power,
    reinforce,
    reinforce_gradient,
    reinforce_terms,
)
from taskspace.learning.rollout import (
    Episode,
    LinearQuadraticTask,
    Rollout,
    evaluate_population,
    policy_rollout,
)
from taskspace.learning.tabular import (
    MDPSimulator,
    TabularOptions,
    TabularResult,
    q_learning,
    sarsa,
    td_lambda,
)

__all__ = [
    "Episode",
    "LinearPolicy",
    "LinearQuadraticTask",
    "MDPSimulator",
    "Policy",
    "PolicySearchOptions",
    "PolicySearchResult",
    "PolicySearchStatus",
    "RBFPolicy",
    "Rollout",
    "TabularOptions",
    "TabularResult",
    "cma_es",
    "enac",
    "enac_gradient",
    "enac_regression",
    "evaluate_population",
    "mu_lambda_es",
    "pi2",
    "policy_rollout",
    "power",
    "q_learning",
    "reinforce",
    "reinforce_gradient",
    "reinforce_terms",
    "sarsa",
    "td_lambda",
]
