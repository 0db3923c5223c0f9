"""The compiled batched L1 epsilon (_planning_kernel.epsilon_l1) against independent references.

References: the textbook definition (one QP per facet of qhull's merged hull, as Dex-Net
computes it), qhull's merged hull of all wrenches (least facet offset), facet enumeration
without qhull, and the closure LP. Every test also checks that the compiled path is the one
that answered (its status), so that a fallback to the qhull path cannot hide a wrong kernel.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import taskspace.grasping.epsilon as eps_module
from taskspace._native import planning_kernel
from taskspace.grasping import (
    closure_lp,
    epsilon_l1_batch,
    epsilon_l1_fast,
    epsilon_linf,
    grasp_epsilon_batch,
    primitive_wrenches,
    primitive_wrenches_batch,
)
from tests.grasping.test_grasping_quality_fast import (
    contact,
    enumerated_epsilon,
    random_grasp,
    textbook_epsilon,
)

KERNEL = planning_kernel()
pytestmark = pytest.mark.skipif(
    KERNEL is None or not hasattr(KERNEL, "epsilon_l1"),
    reason="the compiled kernels are not built",
)
CERTIFIED, ZERO, FLAT, UNCERTIFIED = 1, 2, 0, -4


def compiled(W: np.ndarray, corrupt: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's epsilons and statuses of a batch ``(B, K, 6)``."""
    assert KERNEL is not None
    eps, status, _ = KERNEL.epsilon_l1(
        np.ascontiguousarray(W, dtype=float),
        eps_module.SUPPORT_TOLERANCE,
        eps_module.CERTIFICATE_TOLERANCE,
        eps_module.MARGIN_TOLERANCE,
        corrupt,
    )
    return eps, status


def merged_hull_epsilon(W: np.ndarray) -> float:
    """Least facet offset of qhull's merged hull of all wrenches (0 out of closure)."""
    scale = np.abs(W).max()
    value = max(0.0, float((-ConvexHull(W).equations[:, -1]).min()))
    return value if value > 1e-9 * scale else 0.0


def grasps(k: int, n: int, seed: int, **kw: object) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack([primitive_wrenches(random_grasp(rng, k, **kw), edges=8)[0] for _ in range(n)])


@pytest.mark.parametrize(("k", "n"), [(3, 5), (4, 4), (5, 3)])
def test_compiled_matches_the_textbook_definition(k: int, n: int) -> None:
    """Random 3/4/5-contact grasps: one QP per facet of the merged hull and the closure LP;
    the kernel certified every grasp in closure (and gave the out-of-closure ones 0)."""
    W = grasps(k, n, seed=40 + k, mu=0.7)
    eps, status = compiled(W)
    for w, e, s in zip(W, eps, status):
        scale = np.abs(w).max()
        assert e == pytest.approx(textbook_epsilon(w), rel=1e-9, abs=1e-12 * scale)
        closed = closure_lp(w).closure
        assert (e > 0) == closed
        assert s == (CERTIFIED if closed else ZERO) or (not closed and s == CERTIFIED)
    assert np.count_nonzero(eps) >= 2


@pytest.mark.parametrize(("k", "n"), [(3, 40), (5, 30), (6, 12), (8, 6)])
def test_compiled_matches_the_full_hull(k: int, n: int) -> None:
    """Random grasps of 3/5/6/8 contacts (24-64 wrenches) against qhull's merged hull of all
    wrenches, and the batch entry points agree with the qhull-only path."""
    W = grasps(k, n, seed=50 + k, mu=0.5)
    eps, status = compiled(W)
    expected = np.array([merged_hull_epsilon(w) for w in W])
    scale = np.abs(W).max(axis=(1, 2))
    np.testing.assert_allclose(eps, expected, rtol=1e-9, atol=0)
    assert np.all(np.abs(eps - expected) <= 1e-9 * expected + 1e-12 * scale)
    assert np.all(status > 0)  # the kernel answered every one of these
    assert np.count_nonzero(expected) >= n // 4
    np.testing.assert_allclose(epsilon_l1_batch(W), eps, rtol=0, atol=0)
    np.testing.assert_allclose(epsilon_l1_batch(W, native=False), eps, rtol=1e-9, atol=1e-15)
    assert epsilon_l1_fast(W[0]) == eps[0]


def test_grasp_epsilon_batch_uses_the_kernel_and_equals_the_closed_forms() -> None:
    """Two soft fingers and three point contacts: the kernel's values equal the closed-form
    enumerations (the NumPy path, native=False); 5 contacts equal the qhull path."""
    rng = np.random.default_rng(3)
    positions = 0.04 * rng.standard_normal((50, 2, 3))
    positions[:, 1] = -positions[:, 0] + 0.004 * rng.standard_normal((50, 3))
    normals = -positions + 0.015 * rng.standard_normal((50, 2, 3))
    kw = {"mu": 0.5, "edges": 8, "torsion": 0.005}
    soft = grasp_epsilon_batch(positions, normals, **kw)  # type: ignore[arg-type]
    closed = grasp_epsilon_batch(positions, normals, native=False, **kw)  # type: ignore[arg-type]
    assert 5 <= np.count_nonzero(closed) <= 45
    np.testing.assert_allclose(soft, closed, rtol=1e-9, atol=0)
    _, status = compiled(primitive_wrenches_batch(positions, normals, **kw))  # type: ignore[arg-type]
    assert np.all(status > 0)
    for k in (3, 5):
        normals = rng.standard_normal((60, k, 3))
        positions = -0.05 * normals / np.linalg.norm(normals, axis=2, keepdims=True)
        fast = grasp_epsilon_batch(positions, normals, mu=0.6, edges=8)
        numpy = grasp_epsilon_batch(positions, normals, mu=0.6, edges=8, native=False)
        assert np.count_nonzero(numpy) >= 20
        np.testing.assert_allclose(fast, numpy, rtol=1e-9, atol=0)


def test_degenerate_grasps() -> None:
    """Frictionless contacts (each cone's edges coincide), coplanar contacts, the origin on
    the boundary, and flat wrench sets: right values whichever path answers, and the kernel
    answers where it can (it refuses flat sets: fewer than 7 affinely independent wrenches)."""
    rng = np.random.default_rng(11)
    # frictionless, 9 contacts: 72 wrenches, 9 distinct
    for _ in range(4):
        W, _ = primitive_wrenches(random_grasp(rng, 9, mu=0.0), edges=8)
        distinct = np.unique(W.round(15), axis=0)
        assert len(distinct) == 9
        eps, status = compiled(W[None])
        assert eps[0] == pytest.approx(enumerated_epsilon(distinct), abs=1e-12)
        assert status[0] > 0
    # 9 distinct wrenches around the origin, each 8 times (as frictionless contacts give)
    distinct = rng.standard_normal((9, 6))
    distinct[8] = -0.5 * distinct[:8].sum(axis=0)  # the origin: all weights positive
    W = np.repeat(distinct, 8, axis=0)[rng.permutation(72)]
    eps, status = compiled(W[None])
    assert eps[0] == pytest.approx(enumerated_epsilon(distinct), rel=1e-9)
    assert eps[0] > 0 and status[0] == CERTIFIED
    # coplanar contacts (all in z = 0, normals in the plane), 5 and 6 of them
    for k in (5, 6):
        t = 2 * np.pi * np.arange(k) / k + 0.1
        rim = np.column_stack([np.cos(t), np.sin(t), np.zeros(k)])
        contacts = [contact(list(0.05 * p), list(-p), mu=0.6) for p in rim]
        W, _ = primitive_wrenches(contacts, edges=8)
        eps, status = compiled(W[None])
        assert eps[0] == pytest.approx(textbook_epsilon(W), rel=1e-9, abs=1e-12)
        assert eps[0] > 0 and status[0] == CERTIFIED
    # origin on the boundary: frictionless opposed fingers (the force along z only balances)
    pair = [contact([0, 0, 0.05], [0, 0, -1], mu=0.0), contact([0, 0, -0.05], [0, 0, 1], mu=0.0)]
    W, _ = primitive_wrenches(pair * 3, edges=4)
    eps, status = compiled(W[None])
    assert eps[0] == 0.0 and status[0] != CERTIFIED
    assert epsilon_l1_batch(W[None])[0] == 0.0
    # a flat wrench set: a grasp in closure projected along a random direction (rank 5, the
    # origin inside it in 5-D, so no cheap separation): refused by the kernel, 0 by qhull
    W, _ = primitive_wrenches(random_grasp(rng, 4, mu=0.8), edges=8)
    n = rng.standard_normal(6)
    n /= np.linalg.norm(n)
    flat = W - np.outer(W @ n, n)
    assert epsilon_l1_fast(W) > 0
    eps, status = compiled(flat[None])
    assert status[0] == FLAT and eps[0] == 0.0
    assert epsilon_l1_batch(flat[None])[0] == 0.0 == epsilon_l1_fast(flat, native=False)
    # scale invariance and permutation of the wrenches
    W = grasps(5, 1, seed=5, mu=0.7)[0]
    e = compiled(W[None])[0][0]
    assert e > 0
    perm = W[rng.permutation(len(W))]
    both = compiled(np.stack([perm, 1e-6 * W, 1e6 * W]))[0]
    np.testing.assert_allclose(both, [e, 1e-6 * e, 1e6 * e], rtol=1e-12)


@pytest.mark.parametrize("corrupt", [1, 2])
def test_a_corrupted_certificate_is_refused(corrupt: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The kernel's hull with its nearest facet moved inwards (1) or a neighbour link broken
    (2) before the certificate: every grasp in closure is refused (not certified), and the
    batch then gets the textbook value from the qhull path."""
    W = grasps(5, 6, seed=61, mu=0.7)
    eps, status = compiled(W)
    inside = eps > 0
    assert np.count_nonzero(inside) >= 4 and np.all(status[inside] == CERTIFIED)
    bad, refused = compiled(W, corrupt=corrupt)
    assert np.all(refused[inside] == UNCERTIFIED)
    assert np.all(bad[inside] == 0.0)  # nothing returned for a refused grasp

    def corrupted(W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values, status = compiled(W, corrupt=corrupt)
        return values, status > 0

    monkeypatch.setattr(eps_module, "_compiled", corrupted)
    values = epsilon_l1_batch(W[inside][:2])
    for w, v in zip(W[inside][:2], values):
        assert v == pytest.approx(textbook_epsilon(w), rel=1e-9)


def test_kernel_refuses_other_shapes() -> None:
    assert KERNEL is not None
    with pytest.raises(ValueError, match=r"\(B, K < 65000, 6\)"):
        KERNEL.epsilon_l1(np.zeros((2, 10, 3)), 1e-12, 1e-12, 1e-9)
    # no wrench at all: epsilon 0, status "zero" (the scale of an empty set is not read)
    eps, status, _ = KERNEL.epsilon_l1(np.zeros((2, 0, 6)), 1e-12, 1e-12, 1e-9)
    assert eps.tolist() == [0.0, 0.0] and status.tolist() == [2, 2]
    # 3-D wrenches (planar grasps) take the qhull path
    W = grasps(4, 2, seed=1, mu=0.8)[:, :, [0, 1, 5]]
    np.testing.assert_allclose(epsilon_l1_batch(W), epsilon_l1_batch(W, native=False), rtol=0)


def compiled_linf(W: np.ndarray, owner: list[int], corrupt: int = 0) -> tuple[float, int]:
    assert KERNEL is not None
    eps, status, _ = KERNEL.epsilon_linf(
        W[None],
        np.asarray(owner, dtype=np.int32),
        eps_module.SUPPORT_TOLERANCE,
        eps_module.CERTIFICATE_TOLERANCE,
        eps_module.MARGIN_TOLERANCE,
        eps_module.LINF_MAX_STEPS,
        corrupt,
    )
    return float(eps[0]), int(status[0])


@pytest.mark.parametrize(("k", "edges", "n"), [(3, 3, 4), (4, 3, 2), (3, 4, 2)])
def test_compiled_linf_matches_the_minkowski_sum_hull(k: int, edges: int, n: int) -> None:
    """The L-infinity epsilon from the support of the Minkowski sum against qhull's hull of
    the sum (built vertex by vertex, native=False); the kernel certified those in closure; a
    corrupted certificate is refused (and epsilon_linf then builds the hull)."""
    rng = np.random.default_rng(70 + k + edges)
    inside = 0
    for _ in range(n):
        W, owner = primitive_wrenches(random_grasp(rng, k, mu=0.8), edges=edges)
        expected = epsilon_linf(W, owner, native=False)
        value, status = compiled_linf(W, owner)
        assert value == pytest.approx(expected, rel=1e-9, abs=1e-12)
        assert epsilon_linf(W, owner) == value
        assert value >= epsilon_l1_fast(W) - 1e-12  # the L-infinity space contains the L1
        if expected > 0:
            inside += 1
            assert status == CERTIFIED
            assert compiled_linf(W, owner, corrupt=1) == (0.0, UNCERTIFIED)
    assert inside >= 1
