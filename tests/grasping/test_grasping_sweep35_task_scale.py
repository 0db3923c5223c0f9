"""task_wrench_scale of small task wrenches (sweep35).

The facets facing a task wrench were those with ``a^T t > 1e-15`` (absolute): task wrenches of
size ~1e-15 lost their binding facet (k 14 % too large, silently) and below that k was inf.
Reference: the LP ``max k : sum_i lam_i w_i = k t, sum lam = 1, lam >= 0`` (scipy linprog).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from taskspace.grasping import primitive_wrenches_batch, task_wrench_scale

P = np.array([[0.05, 0.0, 0.0], [-0.05, 0.0, 0.0], [0.0, 0.05, 0.0]])
W = primitive_wrenches_batch(P[None], -P[None] / 0.05, mu=0.5, edges=8)[0]
T = np.array([0.3, -0.2, 1.0, 0.1, 0.0, 0.2])


def _lp_scale(t: np.ndarray) -> float:
    """Largest k with k t in the convex hull of the rows of W."""
    m = len(W)
    c = np.zeros(m + 1)
    c[-1] = -1.0  # maximize k
    A_eq = np.zeros((7, m + 1))
    A_eq[:6, :m] = W.T
    A_eq[:6, -1] = -t
    A_eq[6, :m] = 1.0
    b_eq = np.zeros(7)
    b_eq[6] = 1.0
    res = linprog(c, A_eq=A_eq, b_eq=b_eq, bounds=[(0, None)] * (m + 1), method="highs")
    assert res.status == 0
    return float(res.x[-1])


@pytest.mark.parametrize("scale", [1.0, 1e-15, 1e-16, 1e-20, 1e-100])
def test_task_wrench_scale_is_scale_invariant(scale: float) -> None:
    ref = _lp_scale(T)
    k = task_wrench_scale(W, (T * scale)[None])
    assert k * scale == pytest.approx(ref, rel=1e-7)


def test_zero_task_wrench_is_inf() -> None:
    assert task_wrench_scale(W, np.zeros((1, 6))) == np.inf
    both = task_wrench_scale(W, np.vstack([T, np.zeros(6)]))
    assert both == pytest.approx(_lp_scale(T), rel=1e-7)
