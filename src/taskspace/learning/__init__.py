"""Learning in robotics: datasets, MDPs, policy search, movement primitives.

Chapter 10 of the lecture notes: tabular RL, policy search, movement primitives, behaviour
cloning, apprenticeship learning; Gymnasium environments in :mod:`taskspace.learning.envs`;
IK datasets in :mod:`taskspace.learning.ik_dataset`. Dynamic programming and the HJB
equation (the model-based side) live in :mod:`taskspace.optimal_control`.
"""

from taskspace.learning.dmp import DiscreteDMP, DMPOptions, DMPTrajectory, RhythmicDMP
from taskspace.learning.dmp_task import Coupling, DMPStep, DMPTaskTarget, SphereRepulsion
from taskspace.learning.imitation import BehaviourCloningResult, behaviour_cloning
from taskspace.learning.inverse_rl import (
    ApprenticeshipResult,
    apprenticeship_learning,
    feature_expectations,
)
from taskspace.learning.max_entropy_irl import (
    MaxEntIRLOptions,
    MaxEntIRLResult,
    MaxEntIRLStatus,
    SoftPolicy,
    demonstration_feature_counts,
    expected_feature_counts,
    max_entropy_irl,
    soft_value_iteration,
)
from taskspace.learning.orientation_dmp import (
    OrientationDMP,
    OrientationTrajectory,
    quaternion,
)
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
    pi2_update,
    power,
    power_update,
    reinforce,
    reinforce_gradient,
    reinforce_terms,
)
from taskspace.learning.rollout import (
    Episode,
    LinearQuadraticTask,
    Rollout,
    RolloutError,
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
from taskspace.learning.via_point import ViaPointTask

__all__ = [
    "ApprenticeshipResult",
    "BehaviourCloningResult",
    "Coupling",
    "DMPOptions",
    "DMPStep",
    "DMPTaskTarget",
    "DMPTrajectory",
    "DiscreteDMP",
    "Episode",
    "LinearPolicy",
    "LinearQuadraticTask",
    "MDPSimulator",
    "MaxEntIRLOptions",
    "MaxEntIRLResult",
    "MaxEntIRLStatus",
    "OrientationDMP",
    "OrientationTrajectory",
    "Policy",
    "PolicySearchOptions",
    "PolicySearchResult",
    "PolicySearchStatus",
    "RBFPolicy",
    "RhythmicDMP",
    "Rollout",
    "RolloutError",
    "SoftPolicy",
    "SphereRepulsion",
    "TabularOptions",
    "TabularResult",
    "ViaPointTask",
    "apprenticeship_learning",
    "behaviour_cloning",
    "cma_es",
    "demonstration_feature_counts",
    "enac",
    "enac_gradient",
    "enac_regression",
    "evaluate_population",
    "expected_feature_counts",
    "feature_expectations",
    "max_entropy_irl",
    "mu_lambda_es",
    "pi2",
    "pi2_update",
    "policy_rollout",
    "power",
    "power_update",
    "q_learning",
    "quaternion",
    "reinforce",
    "reinforce_gradient",
    "reinforce_terms",
    "sarsa",
    "soft_value_iteration",
    "td_lambda",
]
