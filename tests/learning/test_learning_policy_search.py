from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import scipy.optimize

from taskspace.errors import InvalidInputError
from taskspace.learning import (
    Episode,
    LinearPolicy,
    LinearQuadraticTask,
    PolicySearchOptions,
    PolicySearchStatus,
    RBFPolicy,
    cma_es,
    enac,
    enac_regression,
    evaluate_population,
    mu_lambda_es,
    pi2,
    power,
    reinforce,
    reinforce_terms,
)


def _task(sigma: float = 0.5) -> LinearQuadraticTask:
    return LinearQuadraticTask(
        A=np.array([[1.0, 0.2], [0.0, 1.0]]),
        B=np.array([[0.0], [0.5]]),
        Q=np.eye(2),
        R=0.1 * np.eye(1),
        x0=np.array([1.0, 0.0]),
        horizon=5,
        sigma=sigma,
        initial_std=0.2,
    )


def _fd_gradient(task: LinearQuadraticTask, theta: np.ndarray) -> np.ndarray:
    h = 1e-6
    return np.array(
        [
            (task.expected_return(theta + h * e) - task.expected_return(theta - h * e)) / (2 * h)
            for e in np.eye(theta.size)
        ]
    )


def test_expected_return_closed_form_against_sampling() -> None:
    task = _task()
    theta = np.array([-1.0, -1.5])
    _, R, _ = task.sample_arrays(theta, 100_000, 0)
    se = R.std() / np.sqrt(R.size)
    assert abs(R.mean() - task.expected_return(theta)) < 4 * se


@pytest.mark.parametrize("theta", [[-1.0, -1.5], [0.5, -0.2]])
def test_reinforce_gradient_against_finite_differences(theta: list[float]) -> None:
    task = _task()
    th = np.array(theta)
    true = _fd_gradient(task, th)
    G, R, _ = task.sample_arrays(th, 100_000, 1)
    terms = reinforce_terms(G, R)
    est = terms.mean(axis=0)
    se = terms.std(axis=0) / np.sqrt(R.size)
    assert np.all(np.abs(est - true) < 4 * se), (est, true, se)
    assert np.linalg.norm(se) < 0.1 * np.linalg.norm(true)  # the test has power


@pytest.mark.parametrize("theta", [[-1.0, -1.5], [0.5, -0.2]])
def test_enac_is_the_natural_gradient(theta: list[float]) -> None:
    task = _task()
    th = np.array(theta)
    natural = np.linalg.solve(task.fisher_information(th), _fd_gradient(task, th))
    G, R, _ = task.sample_arrays(th, 100_000, 2)
    # The sampled Fisher matrix matches the closed form.
    assert G.T @ G / R.size == pytest.approx(task.fisher_information(th), rel=0.03)
    w, J, cov = enac_regression(G, R)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(w - natural) < 4 * se), (w, natural, se)
    assert J == pytest.approx(task.expected_return(th), abs=4 * R.std() / np.sqrt(R.size))


def _optimum(task: LinearQuadraticTask) -> tuple[np.ndarray, float]:
    res = scipy.optimize.minimize(lambda th: -task.expected_return(th), np.zeros(2), tol=1e-12)
    return res.x, -res.fun


def _expected_rollout(task: LinearQuadraticTask):  # type: ignore[no-untyped-def]
    def rollout(theta: np.ndarray, seed: int) -> Episode:
        return Episode(
            total_return=task.expected_return(theta),
            log_likelihood_gradient=np.zeros(2),
            rewards=np.zeros(1),
            steps=task.horizon,
        )

    return rollout


@pytest.mark.parametrize("method", [power, pi2, mu_lambda_es, cma_es])
def test_parameter_exploring_methods_reach_the_optimum(method) -> None:  # type: ignore[no-untyped-def]
    task = _task(sigma=0.0)
    _, best = _optimum(task)
    start = task.expected_return(np.array([0.5, 0.5]))
    res = method(
        _expected_rollout(task),
        np.array([0.5, 0.5]),
        PolicySearchOptions(iterations=60, population=16, elite=4, exploration=1.0),
    )
    final = task.expected_return(res.parameters)
    assert (best - final) < 0.01 * (best - start), (method.__name__, final, best)
    assert res.rollouts == len(res.mean_returns) * 16
    assert res.best_return <= best + 1e-9


@pytest.mark.parametrize("method", [reinforce, enac])
def test_gradient_methods_improve_the_return(method) -> None:  # type: ignore[no-untyped-def]
    task = _task(sigma=0.3)
    _, best = _optimum(LinearQuadraticTask(**{**task.__dict__, "sigma": 0.0}))
    start = np.array([0.5, 0.5])
    lr = 0.02 if method is reinforce else 0.5
    res = method(
        task.rollout,
        start,
        PolicySearchOptions(iterations=30, population=40, learning_rate=lr, seed=3),
    )
    gap0 = best - task.expected_return(start)
    gap = best - task.expected_return(res.parameters)
    assert gap < 0.5 * gap0, (method.__name__, gap, gap0)


def test_target_return_stops_the_search() -> None:
    task = _task(sigma=0.0)
    _, best = _optimum(task)
    res = cma_es(
        _expected_rollout(task),
        np.zeros(2),
        PolicySearchOptions(iterations=200, population=8, target_return=best - 0.05),
    )
    assert res.success and res.status is PolicySearchStatus.TARGET_REACHED
    assert len(res.mean_returns) < 200


def test_rollouts_are_pure_functions_of_parameters_and_seed() -> None:
    task = _task()
    th = np.array([-1.0, -1.0])
    a = task.rollout(th, 7)
    b = task.rollout(th, 7)
    assert a.total_return == b.total_return
    assert a.total_return != task.rollout(th, 8).total_return
    params = [th, th + 0.1, th - 0.1]
    serial = evaluate_population(task.rollout, params, [1, 2, 3])
    with ThreadPoolExecutor(2) as pool:
        threaded = evaluate_population(task.rollout, params, [1, 2, 3], executor=pool)
    assert [e.total_return for e in serial] == [e.total_return for e in threaded]


def test_policies() -> None:
    lin = LinearPolicy(state_dim=2, action_dim=2, bias=True)
    th = np.arange(6.0)
    s = np.array([0.5, -1.0])
    assert lin.mean_action(th, s) == pytest.approx(th.reshape(2, 3) @ [0.5, -1.0, 1.0])
    assert lin.features(s) @ th == pytest.approx(lin.mean_action(th, s))
    # d/dtheta log N(a; Phi theta, sigma^2) by finite differences.
    a = np.array([0.3, 0.1])
    sigma = 0.7

    def logp(t: np.ndarray) -> float:
        return float(-np.sum((a - lin.mean_action(t, s)) ** 2) / (2 * sigma**2))

    fd = np.array([(logp(th + 1e-6 * e) - logp(th - 1e-6 * e)) / 2e-6 for e in np.eye(6)])
    assert lin.log_likelihood_gradient(th, s, a, sigma) == pytest.approx(fd, rel=1e-6)
    rbf = RBFPolicy(centers=np.array([[0.0], [1.0], [2.0]]), width=0.5)
    phi = rbf.basis(np.array([1.0]))
    assert phi.sum() == pytest.approx(1.0) and np.argmax(phi) == 1
    with pytest.raises(InvalidInputError, match="3 finite numbers"):
        rbf.check(np.zeros(2))


def test_errors() -> None:
    task = _task()
    with pytest.raises(InvalidInputError, match="elite"):
        power(task.rollout, np.zeros(2), PolicySearchOptions(population=4, elite=5))
    with pytest.raises(InvalidInputError, match="eNAC needs"):
        enac(task.rollout, np.zeros(2), PolicySearchOptions(population=3, elite=1))
    with pytest.raises(InvalidInputError, match="seeds"):
        evaluate_population(task.rollout, [np.zeros(2)], [1, 2])


def test_cma_es_population_on_the_batch_executor_matches_serial() -> None:
    """The same search through taskspace.batch (local processes) and serially."""
    from taskspace.batch import BatchOptions, Executor
    from taskspace.learning.policy_search import cma_es

    task = _task()
    options = PolicySearchOptions(iterations=4, population=6, seed=3)
    serial = cma_es(task.rollout, np.zeros(2), options)
    with Executor(BatchOptions(backend="processes", workers=2, progress=False)) as ex:
        parallel = cma_es(task.rollout, np.zeros(2), options, executor=ex)
    assert parallel.mean_returns == serial.mean_returns
    assert np.array_equal(parallel.parameters, serial.parameters)


def test_power_update_against_a_hand_computation() -> None:
    from taskspace.learning.policy_search import power_update

    # Costs S = (1, 2, 3), h = 2: w = exp(-2 (S - 1) / 2) = (1, e^-1, e^-2).
    eps = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    w = np.array([1.0, np.exp(-1.0), np.exp(-2.0)])
    expected = (w @ eps) / w.sum()
    np.testing.assert_allclose(power_update(np.array([-1.0, -2.0, -3.0]), eps, 2.0), expected)
    # Equal returns: plain average.
    np.testing.assert_allclose(power_update(np.zeros(3), eps, 2.0), eps.mean(axis=0))
