"""Bad inputs to the finite MDPs and dynamic programming (issue #15): a right answer or a
TaskspaceError, never a bare exception, a truncated value or a NaN value function.

Reference: a 2-state MDP whose values are computed by hand (policy evaluation
``V = (I - gamma P_pi)^-1 R_pi``, closed form for 2 x 2).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.optimal_control import (
    ValueIterationOptions,
    deterministic_mdp,
    evaluate_policy,
    finite_horizon_value_iteration,
    grid_world,
    make_grid,
    make_mdp,
    policy_iteration,
    value_iteration,
)

P1 = np.array([[0.9, 0.1], [0.2, 0.8]])
P2 = np.array([[0.5, 0.5], [0.0, 1.0]])
R = np.array([[1.0, 0.0], [0.0, 2.0]])


def mdp():  # type: ignore[no-untyped-def]
    return make_mdp([P1, P2], R, 0.9)


def test_reference_values() -> None:
    # policy (0, 1): state 1 stays forever with reward 2 -> V1 = 2 / (1 - 0.9) = 20;
    # V0 = 1 + 0.9 (0.9 V0 + 0.1 V1) -> V0 = (1 + 1.8) / (1 - 0.81) = 14.7368...
    V = evaluate_policy(mdp(), [0, 1])
    np.testing.assert_allclose(V, [2.8 / 0.19, 20.0], rtol=1e-12)
    # the optimum (value iteration, hand-checked: action 1 in state 0 gives 0 + 0.9 (V0 + V1)/2)
    res = value_iteration(mdp())
    assert res.success
    v1 = 20.0
    v0 = max(2.8 / 0.19, 0.45 * v1 / (1 - 0.45))
    np.testing.assert_allclose(res.V, [v0, v1], rtol=1e-9)


@pytest.mark.parametrize(
    "transitions",
    [
        [[[np.nan, 1.0], [0.0, 1.0]], P2],  # NaN passed the checks: V = [nan, 20]
        [P1.astype(complex), P2],  # imaginary part dropped
        ["ab", P2],  # bare ValueError
        [[[1.0], [0.0, 1.0]], P2],  # ragged: bare ValueError
        [np.ones((2, 2, 2)), P2],  # bare ValueError (3-D CSR)
        [None, P2],
        None,  # bare TypeError
    ],
)
def test_bad_transitions_are_refused(transitions: object) -> None:
    with pytest.raises(InvalidInputError):
        make_mdp(transitions, R, 0.9)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="at least one state"):
        make_mdp([np.zeros((0, 0))], np.zeros((0, 1)), 0.9)


@pytest.mark.parametrize(
    "kw",
    [
        {"rewards": R.astype(complex)},
        {"rewards": "ab"},
        {"gamma": "0.9"},
        {"gamma": None},
        {"gamma": 0.5j},
        {"gamma": np.array([0.5, 0.5])},
        {"tolerance": np.nan},  # NaN tolerance accepted rows summing to 1.5
        {"tolerance": -1.0},
    ],
)
def test_bad_rewards_gamma_tolerance_are_refused(kw: dict[str, object]) -> None:
    args: dict[str, object] = {"rewards": R, "gamma": 0.9}
    args.update(kw)
    transitions = [1.5 * P1, P2] if "tolerance" in kw else [P1, P2]
    with pytest.raises(InvalidInputError):
        make_mdp(transitions, **args)  # type: ignore[arg-type]


@pytest.mark.parametrize("tolerance", [np.nan, -1.0, "a"])
def test_dp_tolerance_is_checked(tolerance: object) -> None:
    # NaN ran all 100,000 backups and returned MAX_ITERATIONS; "a" was a bare TypeError
    options = ValueIterationOptions(tolerance=tolerance)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="tolerance"):
        value_iteration(mdp(), options)
    with pytest.raises(InvalidInputError, match="tolerance"):
        policy_iteration(mdp(), options)


@pytest.mark.parametrize("value", [[1j, 0.0], "ab"])
def test_initial_value_must_be_real(value: object) -> None:
    with pytest.raises(InvalidInputError):
        value_iteration(mdp(), ValueIterationOptions(initial_value=value))


@pytest.mark.parametrize("policy", [[0.7, 1.2], [np.nan, 1], ["a", 1], [True, False]])
def test_policy_must_hold_integers(policy: object) -> None:
    # [0.7, 1.2] was truncated to [0, 1] and evaluated
    with pytest.raises(InvalidInputError, match="policy"):
        evaluate_policy(mdp(), policy)
    np.testing.assert_allclose(evaluate_policy(mdp(), [0.0, 1.0]), [2.8 / 0.19, 20.0])


@pytest.mark.parametrize("successors", [[[0.5, 1.7], [1, 0]], [[np.nan, 1], [1, 0]], "ab"])
def test_successors_must_be_integers(successors: object) -> None:
    with pytest.raises(InvalidInputError, match="successors"):
        deterministic_mdp(successors, [1.0, 2.0], 0.9)


@pytest.mark.parametrize("horizon", [2.5, np.nan, np.inf, "3", None, 0, 10**13])
def test_finite_horizon_must_be_a_reasonable_integer(horizon: object) -> None:
    # 2.5 / NaN / inf / "3" / None: bare TypeError; 10**13: bare MemoryError (146 TiB)
    with pytest.raises(InvalidInputError, match="horizon"):
        finite_horizon_value_iteration(mdp(), horizon)  # type: ignore[arg-type]
    fh = finite_horizon_value_iteration(mdp(), 1)
    np.testing.assert_allclose(fh.V[0], [1.0, 2.0])  # one step: the best immediate reward


def test_grids_and_grid_worlds_check_their_inputs() -> None:
    with pytest.raises(InvalidInputError):
        make_grid(["abc"])  # bare ValueError
    with pytest.raises(InvalidInputError):
        make_grid([[0.0, 1.0, 2.0]], periods=[np.nan])  # was accepted
    with pytest.raises(InvalidInputError):
        make_grid([])
    with pytest.raises(InvalidInputError):
        grid_world([], gamma=0.9)  # an MDP without states
