"""Gymnasium environments on taskspace robots, registered on import.

* ``taskspace/Pendulum-v0``: pendulum swing-up (:class:`PendulumEnv`, 200 steps), with the
  batched :class:`PendulumVectorEnv` as its vector entry point.
* ``taskspace/CartPole-v0``: cart-pole balancing (:class:`CartPoleEnv`, 500 steps), with the
  batched :class:`CartPoleVectorEnv` as its vector entry point.
* ``taskspace/G1Balance-v0``: G1 balancing after a push, the agent shifting the CoM
  reference of the inverse-dynamics QP (:class:`G1BalanceEnv`, 100 steps).
* ``taskspace/PandaReach-v0``: Panda reaching with joint velocities, terminated on collision
  (:class:`PandaReachEnv`, 100 steps), with the batched :class:`PandaReachVectorEnv` as its
  vector entry point.
"""

import gymnasium as gym

from taskspace.learning.envs.cartpole import CartPoleEnv, CartPoleVectorEnv
from taskspace.learning.envs.g1_balance import G1BalanceEnv
from taskspace.learning.envs.panda_reach import PandaReachEnv, PandaReachVectorEnv
from taskspace.learning.envs.pendulum import PendulumEnv, PendulumVectorEnv

if "taskspace/Pendulum-v0" not in gym.registry:
    gym.register(
        id="taskspace/Pendulum-v0",
        entry_point="taskspace.learning.envs.pendulum:PendulumEnv",
        vector_entry_point="taskspace.learning.envs.pendulum:PendulumVectorEnv",
        max_episode_steps=200,
    )
if "taskspace/CartPole-v0" not in gym.registry:
    gym.register(
        id="taskspace/CartPole-v0",
        entry_point="taskspace.learning.envs.cartpole:CartPoleEnv",
        vector_entry_point="taskspace.learning.envs.cartpole:CartPoleVectorEnv",
        max_episode_steps=500,
        reward_threshold=475.0,
    )

if "taskspace/PandaReach-v0" not in gym.registry:
    gym.register(
        id="taskspace/PandaReach-v0",
        entry_point="taskspace.learning.envs.panda_reach:PandaReachEnv",
        vector_entry_point="taskspace.learning.envs.panda_reach:PandaReachVectorEnv",
        max_episode_steps=100,
    )

if "taskspace/G1Balance-v0" not in gym.registry:
    gym.register(
        id="taskspace/G1Balance-v0",
        entry_point="taskspace.learning.envs.g1_balance:G1BalanceEnv",
        max_episode_steps=100,
    )

__all__ = [
    "CartPoleEnv",
    "CartPoleVectorEnv",
    "G1BalanceEnv",
    "PandaReachEnv",
    "PandaReachVectorEnv",
    "PendulumEnv",
    "PendulumVectorEnv",
]
