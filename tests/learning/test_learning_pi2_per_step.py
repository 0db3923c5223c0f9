"""PI^2 per time step (Theodorou, Buchli and Schaal 2010, Table 2) against a hand computation,
and on the DMP via-point task."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import DiscreteDMP, DMPOptions, PolicySearchOptions, ViaPointTask, pi2
from taskspace.learning.policy_search import pi2_update


def test_pi2_update_against_a_hand_computation() -> None:
    # 2 rollouts, 3 steps, 2 parameters; h = ln 2 so that exp(-h) = 1/2.
    costs = np.array([[1.0, 0.0, 2.0], [0.0, 3.0, 0.0]])
    # Cost-to-go S: rollout 0 (3, 2, 2), rollout 1 (3, 3, 0).
    eps = np.array([[1.0, 0.0], [0.0, 2.0]])
    W = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # w_{j,t_i}: rows steps, columns j
    # Step 0: S equal -> P = (1/2, 1/2), dtheta_0 = (1/2, 1).
    # Step 1: S = (2, 3) -> weights (1, 1/2) -> P = (2/3, 1/3), dtheta_1 = (2/3, 2/3).
    # Step 2: S = (2, 0) -> weights (1/2, 1) -> P = (1/3, 2/3), dtheta_2 = (1/3, 4/3).
    # (N - i) = (3, 2, 1):
    # j = 0: (3 * 1 * 1/2 + 2 * 1 * 2/3) / (3 + 2) = 17/30
    # j = 1: (2 * 1 * 2/3 + 1 * 1 * 4/3) / (2 + 1) = 8/9
    d = pi2_update(costs, eps, np.log(2.0), W)
    assert d == pytest.approx([17 / 30, 8 / 9], abs=1e-14)
    # The episodic form sees only the totals (3, 3): the plain mean of the perturbations.
    assert pi2_update(costs.sum(axis=1), eps, np.log(2.0)) == pytest.approx([0.5, 1.0])
    # A parameter that is never active is not moved.
    W0 = W.copy()
    W0[:, 1] = 0.0
    assert pi2_update(costs, eps, np.log(2.0), W0)[1] == 0.0
    with pytest.raises(InvalidInputError, match="activations"):
        pi2_update(costs, eps, 1.0)
    with pytest.raises(InvalidInputError, match="activations"):
        pi2_update(costs, eps, 1.0, W[:2])


def test_pi2_projection_against_a_hand_computation() -> None:
    # The same rollouts, activations at step 1 = (1, 2); one block: M eps = g g^T eps / g^T g.
    costs = np.array([[1.0, 0.0, 2.0], [0.0, 3.0, 0.0]])
    eps = np.array([[1.0, 0.0], [0.0, 2.0]])
    W = np.array([[1.0, 0.0], [1.0, 2.0], [0.0, 1.0]])
    # Step 0: g = (1, 0): M eps = (1, 0), (0, 0); P = (1/2, 1/2) -> (1/2, 0).
    # Step 1: g = (1, 2): M eps = (1/5)(1, 2), (4/5)(1, 2); P = (2/3, 1/3) -> (0.4, 0.8).
    # Step 2: g = (0, 1): M eps = (0, 0), (0, 2); P = (1/3, 2/3) -> (0, 4/3).
    # j = 0: (3 * 1/2 + 2 * 0.4) / (3 + 2) = 23/50
    # j = 1: (2 * 2 * 0.8 + 1 * 4/3) / (4 + 1) = 68/75
    d = pi2_update(costs, eps, np.log(2.0), W, projection_blocks=1)
    assert d == pytest.approx([23 / 50, 68 / 75], abs=1e-14)
    # Without the projection: step 1 is (2/3, 2/3): j = 1 gives (4 * 2/3 + 4/3) / 5 = 4/5.
    assert pi2_update(costs, eps, np.log(2.0), W) == pytest.approx([17 / 30, 4 / 5], abs=1e-14)
    # Two blocks of one parameter: each projection is the identity (g scalar).
    assert pi2_update(costs, eps, np.log(2.0), W, projection_blocks=2) == pytest.approx(
        [17 / 30, 4 / 5], abs=1e-14
    )
    for bad in (3, 0, True, 1.0):
        with pytest.raises(InvalidInputError, match="projection_blocks"):
            pi2_update(costs, eps, 1.0, W, projection_blocks=bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="projection_blocks"):
        pi2_update(costs.sum(axis=1), eps, 1.0, projection_blocks=1)


def _task() -> ViaPointTask:
    t = np.linspace(0, 1, 101)
    mj = 10 * t**3 - 15 * t**4 + 6 * t**5
    dmp = DiscreteDMP.fit(t, np.stack([mj, mj], axis=1), DMPOptions(num_basis=8))
    return ViaPointTask(dmp=dmp, via_time=0.5, via_point=np.array([0.5, 0.8]))


def test_via_point_per_step_rewards_and_activations() -> None:
    task = _task()
    theta = task.dmp.weights.ravel() + 3.0
    ep = task.rollout(theta, 0)
    traj = task._dmp(theta).rollout(task.dt, duration=task.dmp.tau)
    W = task.activations()
    assert ep.rewards.shape == (traj.time.size,) == (W.shape[0],)
    assert ep.rewards.sum() == pytest.approx(ep.total_return, rel=1e-12)
    # Reference: the episodic cost of the task.
    err = traj.y[50] - task.via_point
    acc = np.sum(traj.ydd**2) * task.dt
    assert ep.total_return == pytest.approx(-(1e3 * err @ err + 1e-4 * acc), rel=1e-12)
    # The activations are the DMP's basis at the rollout's phases, for both dimensions.
    B = task.dmp.basis(traj.phase)
    assert W == pytest.approx(np.hstack([B, B]), abs=1e-15)
    # The forcing shape f / (g - y0) is W @ theta per dimension.
    assert (W[:, :8] @ theta[:8]) == pytest.approx(B @ theta.reshape(2, 8)[0], abs=1e-12)


def test_per_step_pi2_reaches_the_via_point_within_2cm() -> None:
    # Seed 0, sigma 20 decaying by 0.93, 10 rollouts per update, 25 updates = 250 rollouts.
    # Measured (/tmp/g_pi2.py, 5 seeds, 40 updates): a rollout first within 2 cm after
    # median 181 rollouts (174 at seed 0) per step, 176 (161 at seed 0) episodic.
    task = _task()
    options = PolicySearchOptions(
        iterations=25, population=10, elite=4, exploration=20.0, exploration_decay=0.93
    )
    theta0 = task.dmp.weights.ravel()
    res = pi2(task.rollout, theta0, options, activations=task.activations())
    assert res.rollouts == 250
    assert task.via_error(res.parameters) < 0.02
    episodic = pi2(task.rollout, theta0, options)
    assert task.via_error(episodic.parameters) < 0.02
    # The two forms are different updates.
    assert not np.allclose(res.parameters, episodic.parameters)
    # With the paper's projection M of the noise onto each dimension's basis (measured: a
    # rollout within 2 cm after median 191 rollouts, 181 at seed 0).
    projected = pi2(
        task.rollout, theta0, options, activations=task.activations(), projection_blocks=2
    )
    assert task.via_error(projected.parameters) < 0.02


def test_per_step_pi2_errors() -> None:
    task = _task()
    theta0 = task.dmp.weights.ravel()
    with pytest.raises(InvalidInputError, match="activations"):
        pi2(task.rollout, theta0, activations=np.ones((101, 3)))
    with pytest.raises(InvalidInputError, match="per-step rewards"):
        pi2(task.rollout, theta0, activations=np.ones((7, 16)))
    with pytest.raises(InvalidInputError, match="projection_blocks needs activations"):
        pi2(task.rollout, theta0, projection_blocks=2)
