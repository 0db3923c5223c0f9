"""Policy search on rollouts and options it was not designed for (issue #15).

Before: a rollout returning NaN was kept by the (mu, lambda)-ES as its best offspring (argsort
puts NaN last, the ES reverses it) and the search ended "successfully"; inf / -inf returns went
the same way, and REINFORCE / eNAC returned NaN parameters; CMA-ES passed NaN to pycma. A
rollout that raised, returned None, text, a complex number, an array or no Episode at all gave
bare TypeError / ValueError / AttributeError from inside the search. ``cma_es`` with
population 1 or a seed >= 2**32 - 1 gave pycma's bare ValueError, a subnormal exploration its
bare AssertionError. A population of 10**9 tried to allocate the noise (15 GiB); an
``exploration_decay`` > 1 let the noise overflow to inf and the rollout got inf parameters.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, SolverError
from taskspace.learning import (
    Episode,
    PolicySearchOptions,
    RolloutError,
    cma_es,
    evaluate_population,
    mu_lambda_es,
    pi2,
    power,
    reinforce,
)

METHODS = [mu_lambda_es, pi2, power, cma_es, reinforce]
OPTIONS = PolicySearchOptions(iterations=3, population=6, elite=2, seed=4)


def _rollout(total: Callable[[np.ndarray, int], Any]) -> Callable[[np.ndarray, int], Episode]:
    def rollout(theta: np.ndarray, seed: int) -> Episode:
        return Episode(
            total_return=total(theta, seed),
            log_likelihood_gradient=np.ones(theta.size),
            rewards=np.zeros(1),
            steps=1,
        )

    return rollout


def _sphere(theta: np.ndarray, seed: int) -> float:
    return -float(theta @ theta)


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.__name__)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_return_names_the_rollout(method: Any, bad: float) -> None:
    seen: list[tuple[int, np.ndarray]] = []

    def total(theta: np.ndarray, seed: int) -> float:
        seen.append((seed, theta.copy()))
        return bad if len(seen) == 3 else _sphere(theta, seed)

    with pytest.raises(RolloutError, match="must be finite") as info:
        method(_rollout(total), np.ones(3), OPTIONS)
    # the third rollout of the first population, with the seed and parameters it was given
    assert info.value.index == 2
    assert info.value.seed == seen[2][0]
    np.testing.assert_array_equal(info.value.parameters, seen[2][1])


def test_es_never_keeps_a_nan_offspring() -> None:
    """Old code: the ES took the NaN offspring as its elite and reported success."""

    def total(theta: np.ndarray, seed: int) -> float:
        return np.nan if seed % 2 else _sphere(theta, seed)

    with pytest.raises(RolloutError):
        mu_lambda_es(_rollout(total), np.ones(3), OPTIONS)


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.__name__)
@pytest.mark.parametrize(
    ("rollout", "match"),
    [
        (_rollout(lambda t, s: None), "total_return=None, not a real number"),
        (_rollout(lambda t, s: "1.0"), "not a real number"),
        (_rollout(lambda t, s: 1 + 2j), "not a real number"),
        (_rollout(lambda t, s: np.ones(2)), "not a real number"),
        (_rollout(lambda t, s: True), "not a real number"),
        (lambda t, s: 3.0, "returned a float, not an Episode"),
        (lambda t, s: 1 / 0, "raised ZeroDivisionError"),
    ],
    ids=["none", "text", "complex", "array", "bool", "not-episode", "raises"],
)
def test_a_broken_rollout_gives_a_rollout_error(method: Any, rollout: Any, match: str) -> None:
    with pytest.raises(RolloutError, match=match) as info:
        method(rollout, np.ones(3), OPTIONS)
    assert info.value.index == 0


def test_the_rollouts_own_exception_is_the_cause_and_taskspace_errors_pass() -> None:
    def raising(theta: np.ndarray, seed: int) -> Episode:
        raise KeyError("sensor")

    with pytest.raises(RolloutError) as info:
        evaluate_population(raising, [np.zeros(2)], [5])
    assert isinstance(info.value.__cause__, KeyError) and info.value.seed == 5

    def refusing(theta: np.ndarray, seed: int) -> Episode:
        raise InvalidInputError("theta out of range")

    with pytest.raises(InvalidInputError, match="theta out of range"):
        evaluate_population(refusing, [np.zeros(2)], [5])


def test_bad_episode_fields() -> None:
    def ep(**kw: Any) -> Callable[[np.ndarray, int], Episode]:
        base: dict[str, Any] = dict(
            total_return=1.0, log_likelihood_gradient=np.zeros(2), rewards=np.zeros(1), steps=1
        )
        base.update(kw)
        return lambda t, s: Episode(**base)

    cases: list[tuple[dict[str, Any], str]] = [
        (dict(steps=-1), "steps=-1"),
        (dict(steps=2.5), "steps=2.5"),
        (dict(log_likelihood_gradient=np.array([np.nan, 0.0])), "log_likelihood_gradient"),
        (dict(log_likelihood_gradient=[[1.0], [1.0, 2.0]]), "log_likelihood_gradient"),
        (dict(log_likelihood_gradient=None), "log_likelihood_gradient"),
    ]
    for kw, match in cases:
        with pytest.raises(RolloutError, match=match):
            evaluate_population(ep(**kw), [np.zeros(2)], [0])
    # numpy scalars and 0-d arrays are real numbers
    out = evaluate_population(ep(total_return=np.float32(2.5)), [np.zeros(2)], [0])
    assert out[0].total_return == 2.5
    evaluate_population(ep(total_return=np.array(1.0)), [np.zeros(2)], [0])


def test_gradients_of_different_sizes() -> None:
    def rollout(theta: np.ndarray, seed: int) -> Episode:
        return Episode(
            total_return=-float(theta @ theta),
            log_likelihood_gradient=np.zeros(2 + seed % 2),
            rewards=np.zeros(1),
            steps=1,
        )

    with pytest.raises(InvalidInputError, match="one entry per parameter"):
        reinforce(rollout, np.ones(2), OPTIONS)


def test_threads_name_the_failing_rollout() -> None:
    def total(theta: np.ndarray, seed: int) -> float:
        return np.nan if seed == 13 else _sphere(theta, seed)

    params = [np.full(2, float(i)) for i in range(4)]
    with ThreadPoolExecutor(2) as pool, pytest.raises(RolloutError) as info:
        evaluate_population(_rollout(total), params, [10, 11, 12, 13], executor=pool)
    assert info.value.index == 3 and info.value.seed == 13


def test_cma_es_options_pycma_refuses() -> None:
    r = _rollout(_sphere)
    with pytest.raises(InvalidInputError, match="population >= 2"):
        cma_es(r, np.ones(2), PolicySearchOptions(population=1, elite=1))
    with pytest.raises(InvalidInputError, match="seed < 2"):
        cma_es(r, np.ones(2), PolicySearchOptions(population=4, elite=1, seed=2**40))
    with pytest.raises(InvalidInputError, match="exploration >= 1e-300"):
        cma_es(r, np.ones(2), PolicySearchOptions(population=4, elite=1, exploration=1e-320))
    # the other methods take these seeds and a population of 1
    res = mu_lambda_es(r, np.ones(2), PolicySearchOptions(population=1, elite=1, seed=2**40))
    assert np.all(np.isfinite(res.parameters))


def test_population_too_large_is_refused_before_allocating() -> None:
    for population in (10**9, 10**30):
        with pytest.raises(InvalidInputError, match="GiB"):
            mu_lambda_es(
                _rollout(_sphere), np.ones(2), PolicySearchOptions(population=population, elite=1)
            )


@pytest.mark.parametrize("method", [mu_lambda_es, pi2, power], ids=lambda m: m.__name__)
def test_exploration_that_overflows_is_refused(method: Any) -> None:
    seen: list[np.ndarray] = []

    def total(theta: np.ndarray, seed: int) -> float:
        seen.append(theta)
        return 0.0

    options = PolicySearchOptions(
        iterations=10, population=3, elite=1, exploration=1e200, exploration_decay=1e100
    )
    with pytest.raises(InvalidInputError, match="exploration noise overflowed"):
        method(_rollout(total), np.zeros(2), options)
    assert seen and all(np.all(np.isfinite(t)) for t in seen)


def test_a_diverging_gradient_step_raises() -> None:
    """Returns near 1e308 overflow REINFORCE's baseline products; the old code returned NaN."""

    def rollout(theta: np.ndarray, seed: int) -> Episode:
        g = np.random.default_rng(seed).standard_normal(2) * 1e10
        return Episode(
            total_return=1e300 * (seed % 7),
            log_likelihood_gradient=g,
            rewards=np.zeros(1),
            steps=1,
        )

    with (
        pytest.warns(RuntimeWarning, match="overflow"),
        pytest.raises(SolverError, match="not finite"),
    ):
        reinforce(rollout, np.zeros(2), OPTIONS)


def test_valid_search_unchanged_against_a_hand_computed_es_step() -> None:
    """One ES update equals the mean of the elite offspring's noise (computed here)."""
    theta0 = np.array([1.0, -2.0])
    o = PolicySearchOptions(iterations=1, population=5, elite=2, seed=11, exploration=0.3)
    res = mu_lambda_es(_rollout(_sphere), theta0, o)
    rng = np.random.default_rng(np.random.SeedSequence(11).spawn(1)[0])
    noise = 0.3 * rng.standard_normal((5, 2))
    R = [-float(x @ x) for x in theta0 + noise]
    best = sorted(range(5), key=lambda i: -R[i])[:2]
    np.testing.assert_allclose(res.parameters, theta0 + noise[best].mean(axis=0), rtol=1e-15)
    assert res.best_return == max(R)


def test_ctrl_c_inside_a_rollout_is_not_wrapped() -> None:
    """KeyboardInterrupt (Ctrl-C) passes through evaluate_population unchanged."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals need the main thread")

    def rollout(theta: np.ndarray, seed: int) -> Episode:
        signal.raise_signal(signal.SIGINT)
        raise AssertionError("not reached")

    with pytest.raises(KeyboardInterrupt):
        mu_lambda_es(rollout, np.ones(2), OPTIONS)
