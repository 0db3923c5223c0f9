"""Named QP problems with independently known solutions (STYLE rule 16).

Each problem comes with its reference solution, derived by hand from the KKT conditions (the
derivation is in the docstring) or computed by scipy in the test that uses it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import null_space
from scipy.optimize import minimize

from taskspace.qp import INF, HierarchyLevel, QPProblem, RowBlock


@dataclass
class NamedQP:
    """A problem, its reference solution and how the reference was obtained."""

    name: str
    problem: QPProblem
    x: np.ndarray
    reference: str


def _empty(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, n)), np.zeros(0)


def box_qp() -> NamedQP:
    """``min 1/2 x'Hx + g'x``, ``H = [[2, 1], [1, 2]]``, ``g = (-6, -6)``, ``-1 <= x <= (1, 3)``.

    Unconstrained optimum (2, 2) violates ``x0 <= 1``. With ``x0 = 1``: ``2 x1 + 1 - 6 = 0``
    so ``x1 = 2.5``; gradient ``Hx + g = (-1.5, 0)``: multiplier 1.5 >= 0 on ``x0 <= 1``,
    ``x1`` interior. KKT holds: ``x* = (1, 2.5)``.
    """
    H = np.array([[2.0, 1.0], [1.0, 2.0]])
    g = np.array([-6.0, -6.0])
    A, b = _empty(2)
    C, l_ = _empty(2)
    p = QPProblem(H, g, A, b, C, l_, l_.copy(), np.array([-1.0, -1.0]), np.array([1.0, 3.0]))
    return NamedQP("box", p, np.array([1.0, 2.5]), "KKT by hand")


def equality_inequality_qp() -> NamedQP:
    """``min 1/2 |x - c|^2``, ``c = (1, 2, 0)``, ``sum(x) = 1``, ``x0 - x1 >= 0.5``, ``x2 <= 2``.

    Projection of c on the plane gives ``x0 - x1 = -1 < 0.5``, so the inequality is active:
    project c on ``A x = (1, 0.5)`` with ``A = [[1, 1, 1], [1, -1, 0]]``:
    ``lambda = (A A')^-1 (A c - b) = (2/3, -3/4)``, ``x = c - A' lambda = (13/12, 7/12, -2/3)``.
    The multiplier of ``x0 - x1 >= 0.5`` is 3/4 >= 0 and ``x2 <= 2`` and the box are inactive.
    """
    H = np.eye(3)
    c = np.array([1.0, 2.0, 0.0])
    A = np.array([[1.0, 1.0, 1.0]])
    C = np.array([[1.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
    p = QPProblem(
        H,
        -c,
        A,
        np.array([1.0]),
        C,
        np.array([0.5, -INF]),
        np.array([INF, 2.0]),
        np.full(3, -5.0),
        np.full(3, 5.0),
        eq_blocks=[RowBlock("sum", 0, 1)],
        in_blocks=[RowBlock("difference", 0, 1), RowBlock("x2 cap", 1, 2)],
    )
    return NamedQP("eq_ineq", p, np.array([13 / 12, 7 / 12, -2 / 3]), "KKT by hand")


def degenerate_qp() -> NamedQP:
    """Redundant equalities ``x0 + x1 = 1``, ``2 x0 + 2 x1 = 2``, ``x2 = 0.5``; ``x0 <= 0.2``.

    ``min 1/2 |x|^2``: without the bound ``x = (0.5, 0.5, 0.5)``; with ``x0 <= 0.2`` active,
    ``x = (0.2, 0.8, 0.5)`` (multiplier of the bound: ``x1 - x0 = 0.6 >= 0``).
    """
    A = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    C, l_ = _empty(3)
    p = QPProblem(
        np.eye(3),
        np.zeros(3),
        A,
        np.array([1.0, 2.0, 0.5]),
        C,
        l_,
        l_.copy(),
        np.full(3, -INF),
        np.array([0.2, INF, INF]),
    )
    return NamedQP("degenerate", p, np.array([0.2, 0.8, 0.5]), "KKT by hand")


def random_dense_qp(seed: int = 1) -> NamedQP:
    """Random strictly convex QP (n = 8, 2 equalities, 4 inequalities, box); scipy SLSQP."""
    rng = np.random.default_rng(seed)
    n = 8
    M = rng.normal(size=(n, n))
    H = M @ M.T + np.eye(n)
    g = rng.normal(size=n) * 5
    A = rng.normal(size=(2, n))
    b = rng.normal(size=2)
    C = rng.normal(size=(4, n))
    l_ = np.array([-0.5, -INF, -1.0, -0.2])
    u = np.array([0.5, 0.3, INF, 0.2])
    lb, ub = np.full(n, -0.6), np.full(n, 0.6)
    p = QPProblem(H, g, A, b, C, l_, u, lb, ub)
    cons = [{"type": "eq", "fun": lambda x: A @ x - b, "jac": lambda x: A}]
    for i in range(4):
        if l_[i] > -INF:
            cons.append({"type": "ineq", "fun": lambda x, i=i: C[i] @ x - l_[i]})
        if u[i] < INF:
            cons.append({"type": "ineq", "fun": lambda x, i=i: u[i] - C[i] @ x})
    ref = minimize(
        lambda x: 0.5 * x @ H @ x + g @ x,
        np.zeros(n),
        jac=lambda x: H @ x + g,
        constraints=cons,
        bounds=list(zip(lb, ub)),
        method="SLSQP",
        options={"ftol": 1e-13, "maxiter": 1000},
    )
    # SLSQP may stop with "positive directional derivative" once it cannot improve at this
    # ftol (BLAS-threading dependent); accept that end point only if it is feasible
    stalled = "directional derivative" in str(ref.message)
    if not (ref.success or (stalled and p.is_feasible(ref.x, 1e-8))):  # pragma: no cover
        raise RuntimeError(f"scipy reference failed: {ref.message}")
    return NamedQP(f"random_dense_{seed}", p, ref.x, "scipy SLSQP")


PROBLEMS: dict[str, Callable[[], NamedQP]] = {
    "box": box_qp,
    "eq_ineq": equality_inequality_qp,
    "degenerate": degenerate_qp,
    "random_dense_2": lambda: random_dense_qp(2),
    "random_dense_1": lambda: random_dense_qp(1),
}


def infeasible_qp() -> QPProblem:
    """``min 1/2 |x|^2`` with ``x0 + x1 = 4`` (block "sum") and the box ``0 <= x <= 1``.

    Least-violating point of the relaxation ``min 1/2|x|^2 + w/2 (|s_eq|^2 + |s_box|^2)``:
    by symmetry ``x0 = x1 = t > 1`` and ``w (2 (2t - 4) + 2 (t - 1)) + 2 t = 0``, i.e.
    ``t = 10 w / (6 w + 2)`` (-> 5/3 for large w).
    """
    A = np.array([[1.0, 1.0]])
    C, l_ = _empty(2)
    return QPProblem(
        np.eye(2),
        np.zeros(2),
        A,
        np.array([4.0]),
        C,
        l_,
        l_.copy(),
        np.zeros(2),
        np.ones(2),
        eq_blocks=[RowBlock("sum", 0, 1)],
        box_blocks=[RowBlock("box", 0, 2)],
    )


def lexicographic_reference(jacobians: list[np.ndarray], targets: list[np.ndarray]) -> np.ndarray:
    """Strict hierarchy by brute force: level k is a least-squares problem in the nullspace
    of the levels above (scipy.linalg.null_space), then the least-norm point of the final
    optimal set."""
    n = jacobians[0].shape[1]
    x = np.zeros(n)
    Z = np.eye(n)
    for J, y in zip(jacobians, targets):
        if Z.shape[1] == 0:
            break
        JZ = J @ Z
        # singular values below an ABSOLUTE threshold are round-off from directions already
        # used by higher levels (a relative rcond would invert them when JZ is all round-off)
        s_max = float(np.linalg.norm(JZ, 2))
        threshold = 1e-9 * max(1.0, float(np.linalg.norm(J, 2)))
        if s_max <= threshold:
            continue
        rcond = threshold / s_max
        z, *_ = np.linalg.lstsq(JZ, y - J @ x, rcond=rcond)
        x = x + Z @ z
        Z = Z @ null_space(JZ, rcond=rcond)
    # least-norm point of x + range(Z)
    return x - Z @ (Z.T @ x)


def vanished_hard_row() -> dict[str, np.ndarray]:
    """A cascade whose hard row cannot hold in any level: ``A x = 1`` fixes ``x0 + x1``, the
    hard row 0 asks ``x0 + x1 = 3`` (its row ``2 x0 + 2 x1`` vanishes in the null space of
    ``A``); hard row 1 (``-0.5 <= x2 <= 0.5``) holds against the level pulling ``x2`` to 2,
    so ``x2 = 0.5``. Keyword arguments of ``HierarchySolver.solve`` for n = 3, with the
    level list under ``"levels"``."""
    return {
        "levels": [HierarchyLevel("pull", np.array([[0.0, 0.0, 1.0]]), np.array([2.0]))],
        "A": np.array([[1.0, 1.0, 0.0]]),
        "b": np.array([1.0]),
        "C": np.array([[2.0, 2.0, 0.0], [0.0, 0.0, 1.0]]),
        "l": np.array([3.0, -0.5]),
        "u": np.array([3.0, 0.5]),
    }
