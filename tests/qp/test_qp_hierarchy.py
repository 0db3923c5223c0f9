"""HierarchySolver (slides 2:42-2:44): agreement with the exact nullspace formula, priority
preservation, level-1 inequalities, box bounds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from taskspace.qp import (
    INF,
    HierarchyLevel,
    HierarchySolver,
    QPStatus,
    hierarchical_step_exact,
)
from tests.qp.problems_qp import lexicographic_reference


def _random_stack(
    rng: np.random.Generator, n: int, K: int, total_rows: int
) -> list[HierarchyLevel]:
    cuts = np.sort(rng.choice(np.arange(1, total_rows), size=K - 1, replace=False))
    dims = np.diff(np.concatenate([[0], cuts, [total_rows]]))
    return [
        HierarchyLevel(f"L{k}", rng.normal(size=(d, n)), rng.normal(size=d))
        for k, d in enumerate(dims)
    ]


@pytest.mark.parametrize(
    ("K", "n", "rows"),
    [(4, 12, 10), (4, 12, 16), (5, 20, 18), (5, 20, 27), (6, 35, 30), (6, 35, 44)],
)
def test_equality_cascade_equals_exact_nullspace_formula(K: int, n: int, rows: int) -> None:
    rng = np.random.default_rng(K * 1000 + n * 10 + rows)
    levels = _random_stack(rng, n, K, rows)
    if rows % 2 == 0:  # make one level rank-deficient (a row repeated from a higher level)
        levels[2].J[0] = levels[0].J[0]
    Js = [lv.J for lv in levels]
    ys = [lv.r for lv in levels]
    result = HierarchySolver().solve(levels, n)
    assert result.success
    exact = hierarchical_step_exact(Js, ys)
    np.testing.assert_allclose(result.x, exact, atol=1e-6)
    np.testing.assert_allclose(result.x, lexicographic_reference(Js, ys), atol=1e-6)
    # the reported residuals are those of x
    for lv, res in zip(levels, result.residuals):
        assert res == pytest.approx(np.linalg.norm(lv.J @ result.x - lv.r), abs=1e-12)
    # nullspace dimensions: n minus the rank of the stacked Jacobians so far
    for k, dim in enumerate(result.nullspace_dims[:-1]):
        assert dim == n - np.linalg.matrix_rank(np.vstack(Js[: k + 1]))


def test_priority_preserved_under_lower_levels() -> None:
    rng = np.random.default_rng(21)
    n = 12
    J1, J2 = rng.normal(size=(5, n)), rng.normal(size=(5, n))
    J3 = rng.normal(size=(6, n))  # 16 rows > 12: level 3 conflicts with the others
    r1, r2 = rng.normal(size=5), rng.normal(size=5)
    top = [HierarchyLevel("L1", J1, r1), HierarchyLevel("L2", J2, r2)]
    solver = HierarchySolver()
    alone = solver.solve(top, n)
    reference_residuals = alone.residuals
    for trial in range(5):
        r3 = rng.normal(size=6) * 10**trial
        result = HierarchySolver().solve([*top, HierarchyLevel("L3", J3, r3)], n)
        np.testing.assert_allclose(result.residuals[:2], reference_residuals, atol=1e-8)
        np.testing.assert_allclose(J1 @ result.x, J1 @ alone.x, atol=1e-8)
        np.testing.assert_allclose(J2 @ result.x, J2 @ alone.x, atol=1e-8)
    # with box bounds active the higher residuals are still independent of lower levels
    lb, ub = np.full(n, -0.3), np.full(n, 0.3)
    bounded = HierarchySolver().solve(top, n, lb=lb, ub=ub)
    for _ in range(3):
        r3 = rng.normal(size=6) * 5
        result = HierarchySolver().solve([*top, HierarchyLevel("L3", J3, r3)], n, lb=lb, ub=ub)
        np.testing.assert_allclose(result.residuals[:2], bounded.residuals, atol=1e-7)


def test_level1_inequality_beats_lower_levels_hand_example() -> None:
    # L1: x0 <= 1; L2: x0 = 2, x1 = 3; L3: x0 + x1 + x2 = 10  ->  x = (1, 3, 6)
    levels = [
        HierarchyLevel(
            "cap",
            np.zeros((0, 3)),
            np.zeros(0),
            np.array([[1.0, 0, 0]]),
            np.array([-INF]),
            np.array([1.0]),
        ),
        HierarchyLevel("pull", np.array([[1.0, 0, 0], [0, 1, 0]]), np.array([2.0, 3.0])),
        HierarchyLevel("sum", np.array([[1.0, 1, 1]]), np.array([10.0])),
    ]
    result = HierarchySolver().solve(levels, 3)
    assert result.success
    np.testing.assert_allclose(result.x, [1.0, 3.0, 6.0], atol=1e-7)
    assert result.violations[0] <= 1e-9


def test_level1_inequalities_respected_random() -> None:
    rng = np.random.default_rng(22)
    n = 15
    c = 0.2
    idx = np.array([0, 3, 7, 11])
    C = np.eye(n)[idx]
    for _ in range(5):
        # lower levels pull x[idx] far above c
        J2 = np.eye(n)[idx]
        r2 = np.full(len(idx), 2.0) + rng.uniform(0, 1, len(idx))
        J3 = rng.normal(size=(8, n))
        r3 = rng.normal(size=8) * 3
        levels = [
            HierarchyLevel(
                "cap", np.zeros((0, n)), np.zeros(0), C, np.full(4, -INF), np.full(4, c)
            ),
            HierarchyLevel("pull", J2, r2),
            HierarchyLevel("rest", J3, r3),
        ]
        result = HierarchySolver().solve(levels, n)
        assert result.success
        assert np.all(result.x[idx] <= c + 1e-8)
        np.testing.assert_allclose(result.x[idx], c, atol=1e-6)  # pulled onto the cap
        assert result.violations[0] <= 1e-8


def test_infeasible_level1_inequality_minimizes_violation_then_holds_it() -> None:
    # L1 asks x0 >= 2 but the hard box says x0 <= 1: the violation is minimized (x0 = 1) and
    # lower levels cannot make it worse
    n = 3
    levels = [
        HierarchyLevel(
            "want",
            np.zeros((0, n)),
            np.zeros(0),
            np.array([[1.0, 0, 0]]),
            np.array([2.0]),
            np.array([INF]),
        ),
        HierarchyLevel("pull down", np.array([[1.0, 0, 0], [0, 1, 0]]), np.array([-5.0, 0.5])),
    ]
    result = HierarchySolver().solve(levels, n, lb=np.full(n, -1.0), ub=np.full(n, 1.0))
    np.testing.assert_allclose(result.x, [1.0, 0.5, 0.0], atol=1e-7)
    assert result.violations[0] == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("seed", range(4))
def test_box_bounds_always_respected(seed: int) -> None:
    rng = np.random.default_rng(30 + seed)
    n = 14
    levels = _random_stack(rng, n, 4, 18)
    for lv in levels:
        lv.r *= 5.0  # targets far outside the box
    lb = -rng.uniform(0.05, 0.5, n)
    ub = rng.uniform(0.05, 0.5, n)
    result = HierarchySolver().solve(levels, n, lb=lb, ub=ub)
    assert result.status is not QPStatus.FAILED
    assert np.all(result.x >= lb - 1e-8)
    assert np.all(result.x <= ub + 1e-8)


def test_first_level_with_box_matches_scipy() -> None:
    # the first level of a bounded cascade is a bounded least-squares problem
    rng = np.random.default_rng(40)
    n = 6
    J = rng.normal(size=(4, n))
    r = rng.normal(size=4) * 3
    lb, ub = np.full(n, -0.4), np.full(n, 0.4)
    result = HierarchySolver().solve([HierarchyLevel("L1", J, r)], n, lb=lb, ub=ub)
    ref = minimize(
        lambda x: 0.5 * np.sum((J @ x - r) ** 2),
        np.zeros(n),
        jac=lambda x: J.T @ (J @ x - r),
        bounds=list(zip(lb, ub)),
        method="L-BFGS-B",
        options={"ftol": 1e-15, "gtol": 1e-12},
    )
    assert result.residuals[0] == pytest.approx(np.linalg.norm(J @ ref.x - r), abs=1e-6)


@pytest.mark.parametrize("shape", [(3, 8), (8, 8), (12, 5)])
def test_qr_level_matches_the_pseudo_inverse_and_nullspace(shape: tuple[int, int]) -> None:
    """One level of the cascade by QR: least-norm / least-squares step and null(J)."""
    from taskspace.qp.hierarchy import _affine_start, _qr_level

    rng = np.random.default_rng(sum(shape))
    J = rng.normal(size=shape)
    r = rng.normal(size=shape[0])
    step = _qr_level(J, r)
    assert step is not None
    z, basis = step
    np.testing.assert_allclose(z, np.linalg.pinv(J) @ r, atol=1e-10)
    assert basis.shape == (shape[1], max(shape[1] - shape[0], 0))
    np.testing.assert_allclose(J @ basis, 0.0, atol=1e-12)
    np.testing.assert_allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-12)
    if shape[0] < shape[1]:  # the affine start of hard equalities uses the same QR
        x0, Z = _affine_start(J, r, shape[1], 1e-8)
        np.testing.assert_allclose(x0, z, atol=1e-12)
        assert Z is not None and Z.shape == basis.shape


def test_qr_level_declines_rank_deficient_blocks() -> None:
    """Rank-deficient levels go to the damped SVD (the QR answer would be meaningless)."""
    from taskspace.qp.hierarchy import _qr_level

    rng = np.random.default_rng(0)
    J = rng.normal(size=(3, 8))
    J[2] = J[0] + J[1]
    assert _qr_level(J, rng.normal(size=3)) is None
    tall = rng.normal(size=(10, 4))
    tall[:, 3] = tall[:, 0]
    assert _qr_level(tall, rng.normal(size=10)) is None


@pytest.mark.parametrize("shape,rank", [((35, 14), 9), ((6, 10), 4), ((10, 10), 7), ((5, 3), 3)])
def test_pivoted_qr_level_matches_the_svd_on_rank_deficient_blocks(
    shape: tuple[int, int], rank: int
) -> None:
    """Rank-deficient levels: least-norm least-squares step and null(J) as the SVD gives."""
    from taskspace.qp.hierarchy import _pivoted_qr_level

    rng = np.random.default_rng(rank)
    J = rng.normal(size=(shape[0], rank)) @ rng.normal(size=(rank, shape[1]))
    r = rng.normal(size=shape[0])
    step = _pivoted_qr_level(J, r, 1e-8)
    assert step is not None
    z, basis = step
    np.testing.assert_allclose(z, np.linalg.pinv(J, rcond=1e-10) @ r, atol=1e-9)
    assert basis.shape == (shape[1], shape[1] - rank)
    np.testing.assert_allclose(J @ basis, 0.0, atol=1e-10)
    np.testing.assert_allclose(basis.T @ basis, np.eye(shape[1] - rank), atol=1e-12)


def test_pivoted_qr_level_leaves_ill_conditioned_blocks_to_the_damped_svd() -> None:
    from taskspace.qp.hierarchy import _pivoted_qr_level

    rng = np.random.default_rng(1)
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    J = U @ np.diag([1.0, 0.5, 0.2, 1e-7, 0.0, 0.0]) @ V.T  # 1e-7: between 1e-8 and 1e-6
    assert _pivoted_qr_level(J, rng.normal(size=6), 1e-8) is None
