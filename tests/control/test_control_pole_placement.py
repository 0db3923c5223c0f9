from __future__ import annotations

import control as ct
import numpy as np
import pytest

from taskspace.control import (
    PolePlacementMethod,
    PolePlacementOptions,
    acker,
    observer_gain,
    place,
    place_poles,
)
from taskspace.errors import InvalidInputError


def _poles(rng, n):  # type: ignore[no-untyped-def]
    k = n // 2
    pairs = [complex(-rng.uniform(0.5, 3), rng.uniform(0.2, 2)) for _ in range(k // 2)]
    out = [p for c in pairs for p in (c, c.conjugate())]
    while len(out) < n:
        out.append(-rng.uniform(0.5, 4))
    return np.array(out)


@pytest.mark.parametrize("seed", range(5))
def test_acker_matches_python_control(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 3 + seed % 3
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, 1))
    p = _poles(rng, n)
    K = acker(A, B, p)
    ref = np.asarray(ct.acker(A, B, p))
    assert np.allclose(K, ref, rtol=1e-8, atol=1e-8)
    assert np.allclose(np.sort_complex(np.linalg.eigvals(A - B @ K)), np.sort_complex(p), atol=1e-7)
    res = place_poles(A, B, p, PolePlacementOptions(method="ackermann"))
    assert res.method is PolePlacementMethod.ACKERMANN
    assert res.max_error < 1e-7


@pytest.mark.parametrize("seed", range(5))
def test_robust_place_matches_python_control(seed: int) -> None:
    rng = np.random.default_rng(10 + seed)
    n, m = 4 + seed % 3, 2
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    p = _poles(rng, n)
    K = place(A, B, p)
    assert np.allclose(K, ct.place(A, B, p), atol=1e-8)
    assert np.allclose(np.sort_complex(np.linalg.eigvals(A - B @ K)), np.sort_complex(p), atol=1e-7)


def test_robust_better_conditioned_than_ackermann_gain_on_multi_input() -> None:
    # A double integrator pair: two inputs, a repeated pole can be placed only with rank B = 2.
    A = np.kron(np.eye(2), np.array([[0.0, 1.0], [0.0, 0.0]]))
    B = np.kron(np.eye(2), np.array([[0.0], [1.0]]))
    res = place_poles(A, B, [-1.0, -1.0, -2.0, -2.0])
    assert res.max_error < 1e-8
    assert res.eigenvector_condition < 1e3


def test_observer_gain_is_dual_and_matches_python_control() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 4))
    C = rng.normal(size=(1, 4))
    p = [-1.0, -2.0, -3.0, -4.0]
    L = observer_gain(A, C, p)
    assert L.shape == (4, 1)
    assert np.allclose(np.sort(np.linalg.eigvals(A - L @ C).real), np.sort(p), atol=1e-7)
    assert np.allclose(L, ct.place(A.T, C.T, p).T, atol=1e-8)


def test_errors() -> None:
    A = np.diag([1.0, 2.0])
    with pytest.raises(InvalidInputError, match="single input"):
        acker(A, np.eye(2), [-1, -2])
    with pytest.raises(InvalidInputError, match="not controllable"):
        acker(A, [1.0, 0.0], [-1, -2])
    with pytest.raises(InvalidInputError, match="exactly n = 2"):
        place(A, np.eye(2), [-1])
    with pytest.raises(InvalidInputError, match="conjugate pairs"):
        place(A, np.eye(2), [-1 + 1j, -2])
    with pytest.raises(InvalidInputError, match="valid methods are"):
        place(A, np.eye(2), [-1, -2], PolePlacementOptions(method="magic"))
    with pytest.raises(InvalidInputError, match="repeated"):
        place(A, [[1.0], [1.0]], [-1, -1])
    with pytest.raises(InvalidInputError, match="not observable"):
        observer_gain(A, [1.0, 0.0], [-1, -2])


@pytest.mark.parametrize("seed", range(4))
def test_dlqr_cross_term_matches_python_control(seed: int) -> None:
    from taskspace.control import dlqr

    rng = np.random.default_rng(seed)
    n, m = 4, 2
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    Q = 2.0 * np.eye(n)
    R = np.eye(m)
    N = 0.3 * rng.normal(size=(n, m))
    K_ref, S_ref, _ = ct.dlqr(A, B, Q, R, N)
    res = dlqr(A, B, Q, R, N=N)
    assert np.allclose(res.K, K_ref, atol=1e-9)
    assert np.allclose(res.P, S_ref, atol=1e-8 * np.abs(S_ref).max())
    # Without the cross term the gain differs (the test can fail).
    assert not np.allclose(dlqr(A, B, Q, R).K, K_ref, atol=1e-3)


def test_dlqr_cross_term_indefinite_cost() -> None:
    from taskspace.control import dlqr

    with pytest.raises(InvalidInputError, match="positive semidefinite"):
        dlqr(np.eye(2), np.eye(2), np.eye(2), np.eye(2), N=2.0 * np.eye(2))
