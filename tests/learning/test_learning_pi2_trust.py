"""PI^2 / PoWER updates on inputs they were not designed for (issue #15).

Before: NaN costs were averaged away silently, inf costs or a cost spread beyond 1.8e308 gave
a NaN update, per-step costs whose cost-to-go overflowed gave a different (wrong) update, a
temperature <= 0 or NaN was used, negative / NaN activations gave a zero update, complex costs
lost their imaginary part, and no rollout or text costs gave bare NumPy errors.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import pi2_update, power_update


def _reference(S: list[float], eps: np.ndarray, h: float) -> np.ndarray:
    """exp(-h (S - min) / span) weights in exact Python arithmetic on finite spans."""
    lo, hi = min(S), max(S)
    w = np.array([np.exp(-h * ((s - lo) / (hi - lo))) for s in S])
    return w @ eps / w.sum()


def test_huge_cost_spread_gives_the_exact_weights() -> None:
    eps = np.arange(12.0).reshape(4, 3)
    costs = [-1e308, 1e308, 0.0, 0.0]
    # span 2e308 overflows; halved costs give the same normalized costs (0, 1, 1/2, 1/2)
    expected = _reference([c / 2 for c in costs], eps, 10.0)
    w = np.array([1.0, np.exp(-10.0), np.exp(-5.0), np.exp(-5.0)])
    np.testing.assert_allclose(expected, w @ eps / w.sum(), rtol=1e-15)
    np.testing.assert_allclose(pi2_update(np.array(costs), eps, 10.0), expected, rtol=1e-14)
    np.testing.assert_allclose(power_update(-np.array(costs), eps, 10.0), expected, rtol=1e-14)


def test_per_step_costs_whose_cost_to_go_overflows() -> None:
    rng = np.random.default_rng(3)
    c, eps, W = rng.random((6, 4)), rng.standard_normal((6, 3)), rng.random((4, 3))
    small = pi2_update(c, eps, 10.0, W)
    # the update is invariant to scaling the costs; 1e308 * (sums of 4 costs) overflowed
    np.testing.assert_allclose(pi2_update(c * 1e308, eps, 10.0, W), small, rtol=1e-12)
    np.testing.assert_allclose(pi2_update(c * 1e-300, eps, 10.0, W), small, rtol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_costs_and_perturbations_are_refused(bad: float) -> None:
    costs, eps = np.array([1.0, 2.0, 3.0]), np.ones((3, 2))
    with pytest.raises(InvalidInputError, match=r"costs must be finite.*\[1\]"):
        pi2_update(np.array([1.0, bad, 3.0]), eps, 10.0)
    with pytest.raises(InvalidInputError, match="returns must be finite"):
        power_update(np.array([1.0, bad, 3.0]), eps, 10.0)
    with pytest.raises(InvalidInputError, match=r"perturbations must be finite.*\[2\]"):
        pi2_update(costs, np.array([[0.0, 0.0], [0.0, 0.0], [bad, 0.0]]), 10.0)
    with pytest.raises(InvalidInputError, match="costs must be finite"):
        pi2_update(np.array([[1.0, bad], [1.0, 2.0], [0.0, 0.0]]), eps, 10.0, np.ones((2, 2)))


@pytest.mark.parametrize("h", [0.0, -1.0, np.nan, np.inf, "a", None])
def test_temperature_must_be_finite_and_positive(h: object) -> None:
    with pytest.raises(InvalidInputError, match="temperature"):
        pi2_update(np.array([1.0, 2.0]), np.ones((2, 2)), h)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="temperature"):
        power_update(np.array([1.0, 2.0]), np.ones((2, 2)), h)  # type: ignore[arg-type]


@pytest.mark.parametrize("costs", [np.array([1.0 + 1j, 2.0]), ["a", "b"], np.zeros(0), None])
def test_non_real_or_empty_costs_are_refused(costs: object) -> None:
    eps = np.ones((2, 2)) if costs is None or len(costs) else np.ones((0, 2))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError):
        pi2_update(costs, eps, 10.0)  # type: ignore[arg-type]


@pytest.mark.parametrize("w", [-1.0, np.nan])
def test_bad_activations_are_refused(w: float) -> None:
    W = np.ones((2, 2))
    W[1, 0] = w
    with pytest.raises(InvalidInputError, match="activations must be finite and nonnegative"):
        pi2_update(np.ones((3, 2)), np.ones((3, 2)), 10.0, W)
