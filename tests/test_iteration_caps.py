"""Iteration caps of iterative algorithms: one convention, a clear error for anything else.

A cap is an integer (``check_count``): ``inf``, ``nan``, ``2.5``, ``None``, ``True`` or text
raise :class:`InvalidInputError` naming the option, instead of a bare ``TypeError`` from
``range`` (potential field, dynamic programming, Newton-Kleinman, compass-gait and kneed-walker
limit cycles, bug algorithms) or a loop that never ends (``max_attempts=inf`` of the car's
control tree when every motion collides). A valid cap still gives the algorithm's result.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from taskspace.control.riccati import RiccatiOptions, solve_continuous_riccati
from taskspace.errors import InvalidInputError
from taskspace.learning import (
    LinearPolicy,
    LinearQuadraticTask,
    PolicySearchOptions,
    TabularOptions,
    apprenticeship_learning,
    cma_es,
    enac,
    feature_expectations,
    mu_lambda_es,
    pi2,
    policy_rollout,
    power,
    q_learning,
    reinforce,
    sarsa,
    td_lambda,
)
from taskspace.locomotion.compass_gait import CompassGait, LimitCycleOptions, find_limit_cycle
from taskspace.locomotion.kneed_walker import KneedWalker, find_kneed_limit_cycle
from taskspace.optimal_control import (
    DoubleIntegrator,
    FittedValueIterationOptions,
    ValueIterationOptions,
    fitted_value_iteration,
    geometric_axis,
    grid_world,
    make_grid,
    make_mdp,
    policy_iteration,
    t_maze,
    value_iteration,
)
from taskspace.planning.bug import BugOptions, bug1, bug2
from taskspace.planning.car import CarModel, ControlSamplingOptions, grow_control_tree
from taskspace.planning.kinodynamic_rrt import parking_lot
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    PotentialStatus,
    gradient_descent,
)

BAD_CAPS = [math.inf, math.nan, 2.5, None, True, "10", 1j, -1]

RECT = PolygonWorld((Polygon.rectangle(3, -2, 5, 2),), (-2.0, -6.0, 12.0, 6.0))
ASIDE = PolygonWorld((Polygon.rectangle(3, 3, 5, 5),), (-2.0, -6.0, 12.0, 6.0))


def _potential(options: PotentialFieldOptions) -> Any:
    field = PotentialField(ASIDE, (9, 0), options)
    return gradient_descent(field, (0, 0))


def _riccati(options: RiccatiOptions) -> Any:
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    return solve_continuous_riccati(A, B, np.eye(2), 1.0, options, initial_gain=[[1.0, 1.0]])


def _limit_cycle(options: LimitCycleOptions) -> Any:
    return find_limit_cycle(CompassGait(), [-0.2, 1.0, -0.4], options)


def _kneed_limit_cycle(options: LimitCycleOptions) -> Any:
    return find_kneed_limit_cycle(KneedWalker(), [-0.1877, 1.1014, -0.0399], options)


def _fitted(options: FittedValueIterationOptions) -> Any:
    problem = DoubleIntegrator()
    axis = geometric_axis(1.2, 1e-2, 1.5)
    grid = make_grid([axis, axis])
    return fitted_value_iteration(
        grid, geometric_axis(2.0, 1e-2, 1.5), problem.dynamics, problem.cost, options
    )


def _car(options: ControlSamplingOptions) -> Any:
    world, start, _ = parking_lot()
    return grow_control_tree(CarModel(), world, start, options=options)


def _tabular(method: Callable[..., Any]) -> Callable[[TabularOptions], Any]:
    def run(options: TabularOptions) -> Any:
        mdp = t_maze(gamma=0.5)
        rng = np.random.default_rng(0)
        if method is td_lambda:
            res = td_lambda(mdp, value_iteration(mdp).policy, options, rng=rng)
        else:
            res = method(mdp, options, rng=rng)
        # ran every episode (a cap ends the loop, never an allocation error)
        return SimpleNamespace(success=res.episode_returns.size == options.episodes)

    return run


_LQ = LinearQuadraticTask(
    A=np.array([[1.0, 0.2], [0.0, 1.0]]),
    B=np.array([[0.0], [0.5]]),
    Q=np.eye(2),
    R=0.1 * np.eye(1),
    x0=np.array([1.0, 0.0]),
    horizon=5,
    sigma=0.5,
    initial_std=0.2,
)
_SEARCH = PolicySearchOptions(iterations=3, population=4, elite=2)


def _lq_search(task: LinearQuadraticTask) -> Any:
    return reinforce(task.rollout, np.zeros(2), _SEARCH)


def _search(method: Callable[..., Any]) -> Callable[[PolicySearchOptions], Any]:
    return lambda options: method(_LQ.rollout, np.zeros(2), options)


@dataclass(frozen=True)
class _RolloutOptions:
    horizon: int = 5


def _policy_rollout(options: _RolloutOptions) -> Any:
    policy = LinearPolicy(state_dim=1, action_dim=1)

    def step(s: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, float, bool]:
        return s + a, -float(s @ s), False

    rollout = policy_rollout(policy, step, lambda rng: np.ones(1), horizon=options.horizon)
    return mu_lambda_es(rollout, np.zeros(policy.num_parameters), _SEARCH)


@dataclass(frozen=True)
class _IRLOptions:
    max_iterations: int = 50


def _irl(options: _IRLOptions) -> Any:
    mdp, _ = grid_world(["....", "..#.", "...."], gamma=0.9, slip=0.1)
    rng = np.random.default_rng(0)
    S = mdp.num_states
    Phi = rng.uniform(size=(S, 4))
    w = rng.normal(size=4)
    d0 = np.full(S, 1.0 / S)
    expert = value_iteration(make_mdp(mdp.transitions, Phi @ (w / np.linalg.norm(w)), 0.9)).policy
    mu_e = feature_expectations(mdp, expert, Phi, d0)
    return apprenticeship_learning(mdp, Phi, mu_e, d0, max_iterations=options.max_iterations)


# (algorithm, options class, cap field, valid options)
CASES: dict[str, tuple[Callable[[Any], Any], Any, str]] = {
    "potential_field.max_iterations": (
        _potential,
        PotentialFieldOptions(max_iterations=2000),
        "max_iterations",
    ),
    "potential_field.stall_window": (
        _potential,
        PotentialFieldOptions(max_iterations=2000),
        "stall_window",
    ),
    "value_iteration": (
        lambda o: value_iteration(t_maze(gamma=0.5), o),
        ValueIterationOptions(),
        "max_iterations",
    ),
    "policy_iteration": (
        lambda o: policy_iteration(t_maze(gamma=0.5), o),
        ValueIterationOptions(),
        "max_iterations",
    ),
    "newton_kleinman": (
        _riccati,
        RiccatiOptions(method="newton_kleinman"),
        "max_iterations",
    ),
    "compass_gait": (_limit_cycle, LimitCycleOptions(), "max_iterations"),
    "kneed_walker": (_kneed_limit_cycle, LimitCycleOptions(), "max_iterations"),
    "bug1": (lambda o: bug1(RECT, (0, 0), (11, 0), options=o), BugOptions(), "max_hits"),
    "bug2": (lambda o: bug2(RECT, (0, 0), (11, 0), options=o), BugOptions(), "max_hits"),
    "fitted_value_iteration.refinements": (
        _fitted,
        FittedValueIterationOptions(dt=1.0, refinements=1),
        "refinements",
    ),
    "fitted_value_iteration.substeps": (_fitted, FittedValueIterationOptions(dt=1.0), "substeps"),
    "car.max_attempts": (_car, ControlSamplingOptions(n_nodes=5), "max_attempts"),
    "car.n_nodes": (_car, ControlSamplingOptions(n_nodes=5), "n_nodes"),
    "q_learning.episodes": (_tabular(q_learning), TabularOptions(episodes=50), "episodes"),
    "q_learning.max_steps": (_tabular(q_learning), TabularOptions(episodes=50), "max_steps"),
    "sarsa.episodes": (_tabular(sarsa), TabularOptions(episodes=50), "episodes"),
    "sarsa.max_steps": (_tabular(sarsa), TabularOptions(episodes=50), "max_steps"),
    "td_lambda.episodes": (_tabular(td_lambda), TabularOptions(episodes=50), "episodes"),
    "td_lambda.max_steps": (_tabular(td_lambda), TabularOptions(episodes=50), "max_steps"),
    "reinforce.iterations": (_search(reinforce), _SEARCH, "iterations"),
    "reinforce.population": (_search(reinforce), _SEARCH, "population"),
    "enac.iterations": (_search(enac), _SEARCH, "iterations"),
    "power.iterations": (_search(power), _SEARCH, "iterations"),
    "power.elite": (_search(power), _SEARCH, "elite"),
    "pi2.iterations": (_search(pi2), _SEARCH, "iterations"),
    "mu_lambda_es.iterations": (_search(mu_lambda_es), _SEARCH, "iterations"),
    "mu_lambda_es.max_rollouts": (
        _search(mu_lambda_es),
        replace(_SEARCH, max_rollouts=8),
        "max_rollouts",
    ),
    "cma_es.iterations": (_search(cma_es), _SEARCH, "iterations"),
    "apprenticeship_learning": (_irl, _IRLOptions(), "max_iterations"),
    "linear_quadratic_task.horizon": (_lq_search, _LQ, "horizon"),
    "policy_rollout.horizon": (_policy_rollout, _RolloutOptions(), "horizon"),
}

# caps of fixed work, or of loops that end on a criterion only with luck: no huge-cap run
FIXED_WORK = ("n_nodes", "stall_window", "refinements", "substeps", "episodes", "population")
FIXED_WORK += ("elite", "max_rollouts", "horizon")
ENDS_ON_SUCCESS_ONLY = (
    "compass_gait",
    "kneed_walker",
    "reinforce",
    "enac",
    "power",
    "pi2",
    "mu_lambda_es",
)
ENDS_ON_SUCCESS_ONLY += ("cma_es",)


@pytest.mark.parametrize("cap", BAD_CAPS, ids=repr)
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_cap_that_is_not_an_integer_is_refused(case: str, cap: Any) -> None:
    algorithm, options, field = CASES[case]
    if cap is None and field == "max_rollouts":
        pytest.skip("max_rollouts=None means no rollout limit (iterations still caps)")
    with pytest.raises(InvalidInputError, match=field):
        algorithm(replace(options, **{field: cap}))


@pytest.mark.parametrize("case", sorted(CASES))
def test_integral_caps_still_work(case: str) -> None:
    """numpy integers and huge Python integers (clamped to int64) are caps like any other."""
    algorithm, options, field = CASES[case]
    value = getattr(options, field)
    assert algorithm(replace(options, **{field: np.int64(value)})).success
    if field not in FIXED_WORK and case.split(".")[0] not in ENDS_ON_SUCCESS_ONLY:
        assert algorithm(replace(options, **{field: 10**30})).success


def test_a_huge_cap_ends_on_the_algorithms_own_criterion() -> None:
    """The potential field at a local minimum stops by its stall test, not by the cap."""
    cup = Polygon(
        np.array(
            [[4, -2], [6, -2], [6, 2], [4, 2], [4, 1.5], [5.5, 1.5], [5.5, -1.5], [4, -1.5]],
            float,
        )
    )
    field = PotentialField(
        PolygonWorld((cup,), (-2.0, -6.0, 12.0, 6.0)),
        (9, 0),
        PotentialFieldOptions(zeta=1.0, d_star=2.0, eta=0.5, q_star=1.0, max_iterations=10**30),
    )
    assert gradient_descent(field, (0, 0)).status is PotentialStatus.LOCAL_MINIMUM


def _interrupt_after(seconds: float) -> Any:
    """Ctrl-C (``signal.default_int_handler``) delivered by SIGALRM after ``seconds``."""
    import signal

    previous = signal.signal(signal.SIGALRM, signal.default_int_handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    return previous


def _restore(previous: Any) -> None:
    import signal

    signal.setitimer(signal.ITIMER_REAL, 0.0)
    signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("method", [q_learning, sarsa, td_lambda], ids=lambda m: m.__name__)
def test_a_huge_episode_cap_runs_and_ctrl_c_stops_it_cleanly(method: Callable[..., Any]) -> None:
    """10**18 episodes is a valid cap (no preallocation of 10**18 returns); Ctrl-C stops it,
    leaves the MDP as it was, and the next run gives the uninterrupted result."""
    run = _tabular(method)
    options = TabularOptions(episodes=40, max_steps=20)
    mdp = t_maze(gamma=0.5)
    reference = method(
        mdp,
        *([value_iteration(mdp).policy] if method is td_lambda else []),
        options,
        rng=np.random.default_rng(0),
    )
    previous = _interrupt_after(0.3)
    try:
        with pytest.raises(KeyboardInterrupt):
            run(replace(options, episodes=10**18))
    finally:
        _restore(previous)
    again = method(
        mdp,
        *([value_iteration(mdp).policy] if method is td_lambda else []),
        options,
        rng=np.random.default_rng(0),
    )
    np.testing.assert_array_equal(again.V, reference.V)
    np.testing.assert_array_equal(again.episode_returns, reference.episode_returns)


def test_ctrl_c_during_a_policy_search_leaves_the_initial_parameters() -> None:
    theta0 = np.array([-1.0, -1.5])
    calls = 0

    def rollout(theta: Any, seed: int) -> Any:
        nonlocal calls
        calls += 1
        if calls == 7:
            raise KeyboardInterrupt
        return _LQ.rollout(theta, seed)

    with pytest.raises(KeyboardInterrupt):
        power(rollout, theta0, _SEARCH)
    np.testing.assert_array_equal(theta0, [-1.0, -1.5])
    first = power(_LQ.rollout, theta0, _SEARCH)
    second = power(_LQ.rollout, theta0, _SEARCH)
    np.testing.assert_array_equal(first.parameters, second.parameters)
