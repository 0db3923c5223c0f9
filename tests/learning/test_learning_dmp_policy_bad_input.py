# mypy: disable-error-code="arg-type,call-arg"
"""DMPs, policies, policy rollouts and the via-point task on bad input (issue #15).

Before: ``DMPOptions`` took 0 or 2.5 basis functions, NaN or negative gains; DMPs took NaN
weights, weights of the wrong shape, ``tau`` 0 or NaN; a rollout with ``dt=1e-9`` ran for
hours, ``duration=1e9`` was a bare MemoryError (745 GiB), ``inf`` an OverflowError, ``-1`` a
ValueError; NaN goals, goal changes and initial velocities gave NaN trajectories; a 3 x 3
"rotation" full of NaN was integrated. Policies: a state of the wrong size was a bare matmul
ValueError, a NaN state a NaN action, ``sigma=0`` NaN gradients, ``LinearPolicy(2.5, 1)`` and
NaN RBF centers were accepted. ``policy_rollout``: a NaN reward gave a NaN return, a text
reward or a step returning None bare errors. ``ViaPointTask``: a via time after the end was an
IndexError, NaN a ValueError, a NaN via point a NaN return.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import (
    DiscreteDMP,
    DMPOptions,
    LinearPolicy,
    OrientationDMP,
    RBFPolicy,
    RhythmicDMP,
    ViaPointTask,
    policy_rollout,
)

OPTIONS = DMPOptions(num_basis=10)
W = np.zeros((1, 10))


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(num_basis=0),
        dict(num_basis=2.5),
        dict(num_basis=10**9),
        dict(alpha_z=float("nan")),
        dict(alpha_z=-1.0),
        dict(alpha_x=0.0),
        dict(alpha_g=float("inf")),
        dict(regularization=-1.0),
    ],
)
def test_dmp_options(kwargs: dict[str, Any]) -> None:
    with pytest.raises(InvalidInputError):
        DMPOptions(**kwargs)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((np.full((1, 10), np.nan), [0.0], [1.0], 1.0), "weights must be finite"),
        ((np.zeros((1, 9)), [0.0], [1.0], 1.0), "num_basis = 10"),
        ((W, [0.0], [1.0], 0.0), "tau"),
        ((W, [0.0], [1.0], float("nan")), "tau"),
        ((W, [0.0j], [1.0], 1.0), "complex"),
        ((W, [0.0], [1.0, 2.0], 1.0), "goal must have shape"),
        ((W, [np.inf], [1.0], 1.0), "y0"),
    ],
)
def test_discrete_dmp_construction(args: tuple[Any, ...], match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        DiscreteDMP(*args, OPTIONS)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(dt=1e-9), "samples"),
        (dict(dt=0.01, duration=1e9), "samples"),
        (dict(dt=0.01, duration=float("inf")), "duration"),
        (dict(dt=0.01, duration=-1.0), "duration"),
        (dict(dt=0.0), "dt"),
        (dict(dt=0.01, goal=[np.nan]), "goal"),
        (dict(dt=0.01, yd0=[np.inf]), "yd0"),
        (dict(dt=0.01, tau=0.0), "tau"),
        (dict(dt=0.01, goal_changes=((0.5, [np.nan]),)), "goal_changes\\[0\\] goal"),
        (dict(dt=0.01, goal_changes=((np.nan, [2.0]),)), "goal_changes\\[0\\] time"),
        (dict(dt=0.01, goal_changes=((0.5,),)), "pair"),
        (dict(dt=0.01, goal_changes="x"), "pairs"),
    ],
)
def test_discrete_dmp_rollout(kwargs: dict[str, Any], match: str) -> None:
    dmp = DiscreteDMP(W, [0.0], [1.0], 1.0, OPTIONS)
    start = time.perf_counter()
    with pytest.raises(InvalidInputError, match=match):
        dmp.rollout(**kwargs)
    assert time.perf_counter() - start < 2.0  # refused before integrating or allocating


def test_valid_dmp_rollouts_unchanged() -> None:
    """The spring without forcing: y reaches the goal like the analytic critically damped
    response ``g - (g - y0)(1 + w t) exp(-w t)``, ``w = alpha_z / (2 tau)``."""
    dmp = DiscreteDMP(W, 0.0, 1.0, 1.0, OPTIONS)  # scalars are taken for d = 1
    traj = dmp.rollout(1e-4, duration=1.0, goal_changes=((0.0, 1.0),))
    w = OPTIONS.alpha_z / 2.0
    exact = 1.0 - (1.0 + w * traj.time) * np.exp(-w * traj.time)
    np.testing.assert_allclose(traj.y[:, 0], exact, atol=2e-3)


def test_rhythmic_and_orientation_dmps() -> None:
    rd = RhythmicDMP(W, [0.0], 1.0, OPTIONS)
    for kwargs in (
        dict(dt=0.01, duration=1e9),
        dict(dt=0.01, duration=float("inf")),
        dict(dt=0.01, duration=1.0, amplitude=float("nan")),
    ):
        with pytest.raises(InvalidInputError):
            rd.rollout(**kwargs)
    with pytest.raises(InvalidInputError, match="finite rotation"):
        OrientationDMP(np.zeros((3, 10)), np.full((3, 3), np.nan), np.eye(3), 1.0, OPTIONS)
    with pytest.raises(InvalidInputError, match="finite rotation"):
        OrientationDMP(np.zeros((3, 10)), 2 * np.eye(3), np.eye(3), 1.0, OPTIONS)
    od = OrientationDMP(np.zeros((3, 10)), np.eye(3), [0.0, 0.0, 0.0, 1.0], 1.0, OPTIONS)
    with pytest.raises(InvalidInputError, match="angular_velocity0"):
        od.rollout(0.01, angular_velocity0=[np.nan, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="samples"):
        od.rollout(1e-9)


def test_policies() -> None:
    p = LinearPolicy(2, 1)
    theta = np.array([1.0, -2.0])
    assert p.mean_action(theta, [3.0, 1.0]) == pytest.approx([1.0])  # 1*3 - 2*1
    with pytest.raises(InvalidInputError, match="state must have shape"):
        p.mean_action(theta, [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="state has non-finite"):
        p.mean_action(theta, [np.nan, 0.0])
    with pytest.raises(InvalidInputError, match="theta has non-finite"):
        p.mean_action([np.nan, 0.0], [1.0, 0.0])
    with pytest.raises(InvalidInputError, match="2 finite numbers"):
        p.mean_action([0.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InvalidInputError, match="text"):
        p.mean_action(theta, "ab")
    with pytest.raises(InvalidInputError, match="sigma"):
        p.log_likelihood_gradient(theta, [1.0, 0.0], [0.0], 0.0)
    with pytest.raises(InvalidInputError, match="action must have shape"):
        p.log_likelihood_gradient(theta, [1.0, 0.0], [0.0, 1.0], 1.0)
    for args in ((2.5, 1), (0, 1), (2, 0), (True, 1)):
        with pytest.raises(InvalidInputError):
            LinearPolicy(*args)
    assert LinearPolicy(0, 1, bias=True).num_parameters == 1  # a constant policy
    with pytest.raises(InvalidInputError, match="centers"):
        RBFPolicy(np.full((3, 1), np.nan), 1.0)
    with pytest.raises(InvalidInputError, match="action_dim"):
        RBFPolicy(np.zeros((3, 1)), 1.0, action_dim=0)


@pytest.mark.parametrize(
    ("step", "match"),
    [
        (lambda s, a: (s, float("nan"), False), "reward nan at step 0"),
        (lambda s, a: (s, "x", False), "reward 'x'"),
        (lambda s, a: None, "must return \\(next_state, reward, done\\)"),
        (lambda s, a: (s, 0.0, False) if s[0] < 1 else (s[:1], 0.0, False), None),
    ],
)
def test_policy_rollout_checks_the_step(step: Any, match: str | None) -> None:
    policy = LinearPolicy(2, 1)
    rollout = policy_rollout(policy, step, lambda rng: np.zeros(2), horizon=3)
    if match is None:  # a state that loses a dimension: the policy names it
        rollout = policy_rollout(
            policy, lambda s, a: (np.zeros(3), 0.0, False), lambda rng: np.zeros(2), horizon=3
        )
        match = "state must have shape"
    with pytest.raises(InvalidInputError, match=match):
        rollout(np.zeros(2), 0)


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_via_point_task() -> None:
    dmp = DiscreteDMP(W, [0.0], [1.0], 1.0, OPTIONS)
    for kwargs, match in (
        (dict(via_time=5.0, via_point=[0.5]), "after the rollout's end"),
        (dict(via_time=float("nan"), via_point=[0.5]), "via_time"),
        (dict(via_time=0.5, via_point=[np.nan]), "via_point"),
        (dict(via_time=0.5, via_point=[0.5], dt=0.0), "dt"),
        (dict(via_time=0.5, via_point=[0.5], via_weight=-1.0), "via_weight"),
    ):
        with pytest.raises(InvalidInputError, match=match):
            ViaPointTask(dmp, **kwargs)
    task = ViaPointTask(dmp, 0.5, [0.5])
    with pytest.raises(InvalidInputError, match="overflowed"):
        task.rollout(np.full(10, 1e300), 0)


def test_tabular_simulator_and_learners_check_their_mdp() -> None:
    from taskspace.learning import MDPSimulator, TabularOptions, q_learning
    from taskspace.optimal_control.mdp import t_maze

    mdp = t_maze()
    rng = np.random.default_rng(0)
    sim = MDPSimulator(mdp, rng)
    for s, a in ((999, 0), (0, 999), (-1, 0), (0.5, 0), (True, 0)):
        with pytest.raises(InvalidInputError, match="must be an integer in"):
            sim.step(s, a)  # was a bare IndexError; -1 silently the last state
    s2, r = sim.step(0, 0)
    assert 0 <= s2 < mdp.num_states and r == mdp.rewards[0, 0]
    with pytest.raises(InvalidInputError, match="mdp must be an MDP"):
        q_learning("maze", TabularOptions(episodes=1), rng=rng)  # was an AttributeError


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_irl_and_imitation_inputs() -> None:
    from taskspace.learning import behaviour_cloning, max_entropy_irl, soft_value_iteration
    from taskspace.optimal_control.mdp import t_maze

    mdp = t_maze()
    S = mdp.num_states
    start = np.full(S, 1.0 / S)
    with pytest.raises(InvalidInputError, match="horizon x states x actions"):
        max_entropy_irl(mdp, np.eye(S), np.full(S, 0.5), start, 10**9)  # was a MemoryError
    with pytest.raises(InvalidInputError, match="horizon x states x actions"):
        soft_value_iteration(mdp, np.zeros(S), 10**9)
    with pytest.raises(InvalidInputError, match="soft values overflowed"):
        soft_value_iteration(mdp, np.full(S, 1e308), 5)  # inf values, NaN policy before
    soft = soft_value_iteration(mdp, np.zeros(S), 3)
    # zero rewards: every action equally likely
    np.testing.assert_allclose(soft.policy, 1.0 / mdp.num_actions)
    with pytest.raises(InvalidInputError, match="policy must be a Policy"):
        behaviour_cloning("linear", np.zeros((5, 2)), np.zeros((5, 1)))
    with pytest.raises(InvalidInputError, match="complex"):
        behaviour_cloning(LinearPolicy(2, 1), np.zeros((5, 2)) + 1j, np.zeros((5, 1)))
