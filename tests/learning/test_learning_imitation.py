from __future__ import annotations

import numpy as np
import pytest

from taskspace.control import dlqr
from taskspace.errors import InvalidInputError
from taskspace.learning import LinearPolicy, LinearQuadraticTask, RBFPolicy, behaviour_cloning


def _demonstrations(noise: float, seed: int):  # type: ignore[no-untyped-def]
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    B = np.array([[0.005], [0.1]])
    K = dlqr(A, B, np.eye(2), 0.1).K  # the demonstrator: discrete LQR, u = -K x
    rng = np.random.default_rng(seed)
    states, actions = [], []
    for _ in range(10):
        x = rng.uniform(-1, 1, 2)
        for _ in range(20):
            u = -K @ x + noise * rng.standard_normal(1)
            states.append(x.copy())
            actions.append(u)
            x = A @ x + B @ u
    return A, B, K, np.array(states), np.array(actions)


def test_cloning_an_lqr_demonstrator_recovers_its_gain() -> None:
    _, _, K, S, U = _demonstrations(0.0, 0)
    res = behaviour_cloning(LinearPolicy(state_dim=2, action_dim=1), S, U)
    assert res.rank == 2
    assert res.parameters == pytest.approx(-K.ravel(), abs=1e-10)
    assert res.residual_rms < 1e-12


def test_noisy_demonstrations_give_a_close_gain_and_return() -> None:
    A, B, K, S, U = _demonstrations(0.05, 1)
    res = behaviour_cloning(LinearPolicy(state_dim=2, action_dim=1), S, U)
    assert np.linalg.norm(res.parameters + K.ravel()) < 0.1 * np.linalg.norm(K)
    task = LinearQuadraticTask(
        A=A, B=B, Q=np.eye(2), R=0.1 * np.eye(1), x0=np.array([1.0, 0.0]), horizon=50, sigma=0.0
    )
    expert = task.expected_return(-K.ravel())
    assert task.expected_return(res.parameters) == pytest.approx(expert, rel=0.02)


def test_rank_deficient_demonstrations_are_reported() -> None:
    # Only states on a line: the gain is not identifiable; the ridge gives a finite answer.
    S = np.outer(np.linspace(-1, 1, 20), [1.0, 2.0])
    U = S @ np.array([0.5, -0.2])
    res = behaviour_cloning(LinearPolicy(state_dim=2, action_dim=1), S, U, regularization=1e-6)
    assert res.rank == 1
    assert np.all(np.isfinite(res.parameters))


def test_rbf_policy_and_errors() -> None:
    pol = RBFPolicy(centers=np.linspace(-1, 1, 9)[:, None], width=0.2)
    s = np.linspace(-1, 1, 200)[:, None]
    a = np.sin(2 * s[:, 0])
    res = behaviour_cloning(pol, s, a, regularization=1e-9)
    assert res.residual_rms < 0.05
    with pytest.raises(InvalidInputError, match="as many states"):
        behaviour_cloning(pol, s, a[:10])
