"""Force and form closure, with a certificate either way.

A grasp is in force closure when its contacts can resist any external wrench: the origin of
wrench space lies strictly inside the convex hull of the primitive wrenches ``w_k`` (the cone
edges of every contact). Two independent tests are provided:

* the linear program (Gordan's alternative): the grasp is *not* in closure exactly when some
  ``c != 0`` has ``c^T w_k >= 0`` for every ``k``; ``c`` is then the certificate, the normal
  of a hyperplane through the origin with every primitive wrench on one side: no combination
  of contact forces can push the object along ``-c``. Found by ``linprog`` (HiGHS) from
  ``W c >= 0, sum_k w_k^T c = 1``.
* the convex hull (qhull): in closure exactly when every facet of ``conv{w_k}`` has the origin
  strictly on its inner side; the least margin is the Ferrari-Canny epsilon (L1).

Form closure (first order) is force closure with frictionless contacts.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

from taskspace._validation import as_float_array, check_positive
from taskspace.errors import InvalidInputError
from taskspace.grasping.contact import (
    ContactType,
    GraspContact,
    check_contacts,
    check_edges,
    primitive_wrenches,
)

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ClosureResult:
    """The answer of a closure test.

    Attributes:
        closure: True when the grasp resists every external wrench.
        certificate: when not in closure, a unit wrench direction ``c`` with ``c^T w >= 0`` for
            every wrench the grasp can apply (so it cannot apply ``-c``); None in closure.
        margin: how deep the origin is inside (LP: the least coefficient of a convex
            combination of the primitive wrenches that gives zero, hull: the epsilon metric);
            0 when not in closure.
        method: ``"lp"`` or ``"hull"``.
        rank: rank of the primitive wrenches (6 is necessary for closure).
    """

    closure: bool
    certificate: FloatArray | None
    margin: float
    method: str
    rank: int


def _rank(W: FloatArray) -> int:
    """Numerical rank of ``W`` relative to its largest entry (closure is scale-invariant)."""
    scale = float(np.abs(W).max())
    return int(np.linalg.matrix_rank(W, tol=1e-9 * scale)) if scale > 0 else 0


def check_wrenches(W: object, name: str = "W") -> tuple[FloatArray, float]:
    """``(W / s, s)``: finite ``(K, d)`` wrenches (``K, d >= 1``) divided by ``s = max |W|``.

    Closure does not depend on the scale of the wrenches; dividing by the largest entry keeps
    the LP and qhull in a well-conditioned range (wrenches of 1e300 or 1e-300 N).
    """
    arr = as_float_array(W, name)
    if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise InvalidInputError(
            f"{name} must be a (K, d) array of wrenches, one a row (K, d >= 1), got shape "
            f"{arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name} must be finite (no NaN or inf entries)")
    scale = float(np.abs(arr).max())
    if scale == 0.0:
        return arr, 1.0
    return arr / scale, scale


def _check_tolerance(tolerance: object) -> float:
    if isinstance(tolerance, (bool, np.bool_)):
        raise InvalidInputError(f"tolerance must be a number >= 0, got {tolerance!r}")
    return check_positive(tolerance, "tolerance", strict=False)


def closure_lp(W: FloatArray, tolerance: float = 1e-9) -> ClosureResult:
    """Force closure of primitive wrenches ``W`` (rows) by linear programming.

    Args:
        W: primitive wrenches, shape ``(K, 6)`` (any dimension ``d`` works: ``(K, d)``).
        tolerance: the least margin counted as strictly inside (the margin, a convex
            combination coefficient, does not depend on the scale of ``W``).
    """
    W, _ = check_wrenches(W)
    tolerance = _check_tolerance(tolerance)
    k, d = W.shape
    rank = _rank(W)
    # Certificate LP: W c >= 0 and sum(W c) = 1, c free. Feasible <=> not in closure.
    cert = linprog(
        np.zeros(d),
        A_ub=-W,
        b_ub=np.zeros(k),
        A_eq=W.sum(axis=0)[None, :],
        b_eq=[1.0],
        bounds=[(None, None)] * d,
        method="highs",
    )
    if cert.status == 0:
        c = np.asarray(cert.x)
        return ClosureResult(False, c / np.linalg.norm(c), 0.0, "lp", rank)
    if rank < d:  # a wrench orthogonal to every w_k; only when sum(W) = 0 can the LP miss it
        c = np.linalg.svd(W)[2][-1]
        return ClosureResult(False, c, 0.0, "lp", rank)
    # Margin: max t s.t. W^T lam = 0, sum lam = 1, lam >= t.
    res = linprog(
        np.hstack([np.zeros(k), -1.0]),
        A_ub=np.hstack([-np.eye(k), np.ones((k, 1))]),
        b_ub=np.zeros(k),
        A_eq=np.vstack([np.hstack([W.T, np.zeros((d, 1))]), np.hstack([np.ones(k), 0.0])]),
        b_eq=np.hstack([np.zeros(d), 1.0]),
        bounds=[(0, None)] * k + [(None, 1.0)],
        method="highs",
    )
    margin = float(res.x[-1]) if res.status == 0 else 0.0
    if margin <= tolerance:  # on the boundary: the LP above says no c with sum > 0 exists
        c = np.linalg.svd(W)[2][-1]
        return ClosureResult(False, c, 0.0, "lp", rank)
    return ClosureResult(True, None, margin, "lp", rank)


def closure_hull(W: FloatArray, tolerance: float = 1e-9) -> ClosureResult:
    """Force closure of primitive wrenches ``W`` (rows) by the convex-hull criterion.

    The margin is ``min_facets -b`` for the hull's facets ``a^T w + b <= 0`` (``|a| = 1``):
    the radius of the largest ball around the origin inside the hull (in the units of ``W``;
    ``tolerance`` is relative to the largest entry of ``W``).
    """
    W, scale = check_wrenches(W)
    tolerance = _check_tolerance(tolerance)
    d = W.shape[1]
    rank = _rank(W)
    if rank < d or W.shape[0] <= d:
        c = np.linalg.svd(W)[2][-1] if rank < d else closure_lp(W).certificate
        return ClosureResult(False, c, 0.0, "hull", rank)
    if d == 1:  # qhull needs 2-D points; the hull of scalars is [min, max]
        margin = min(-float(W.min()), float(W.max()))
        if margin <= tolerance:
            return ClosureResult(False, np.array([1.0 if W.min() >= 0 else -1.0]), 0.0, "hull", 1)
        return ClosureResult(True, None, margin * scale, "hull", 1)
    try:
        hull = ConvexHull(W)
    except QhullError:
        c = np.linalg.svd(W)[2][-1]
        return ClosureResult(False, c, 0.0, "hull", rank)
    offsets = hull.equations[:, -1]
    worst = int(np.argmax(offsets))
    margin = float(-offsets[worst])
    if margin <= tolerance:
        a = hull.equations[worst, :-1]  # a^T w <= -b <= 0 for all w: c = -a
        return ClosureResult(False, -a / np.linalg.norm(a), 0.0, "hull", rank)
    return ClosureResult(True, None, margin * scale, "hull", rank)


def force_closure(
    contacts: list[GraspContact],
    *,
    edges: int = 8,
    method: str = "lp",
    center: FloatArray | None = None,
    torque_scale: float | None = None,
    exact_cone: bool = False,
) -> ClosureResult:
    """Whether the contacts hold the object in force closure.

    Args:
        contacts: the grasp.
        edges: edges of each linearized friction cone.
        method: ``"lp"`` or ``"hull"``.
        center: moment reference point [m] (default: origin of the object frame).
        torque_scale: moment scale ``rho`` [m] (default: the grasp radius).
        exact_cone: decide for the exact (circular) friction cones: the inscribed pyramid in
            closure proves closure, the circumscribed one out of closure disproves it; the
            number of edges doubles until one of them decides (up to 1024).

    Returns:
        The answer with a certificate when not in closure.
    """
    tests = {"lp": closure_lp, "hull": closure_hull}
    contacts = check_contacts(contacts)
    edges = check_edges(edges)
    if not isinstance(exact_cone, (bool, np.bool_)):
        raise InvalidInputError(f"exact_cone must be True or False, got {exact_cone!r}")
    if not isinstance(method, str) or method not in tests:
        raise InvalidInputError(f"unknown closure method {method!r}; valid methods are: hull, lp")
    test = tests[method]

    def run(m: int, mu_scale: float) -> ClosureResult:
        W, _ = primitive_wrenches(
            contacts, edges=m, center=center, torque_scale=torque_scale, mu_scale=mu_scale
        )
        return test(W)

    if not exact_cone or all(c.type is ContactType.FRICTIONLESS for c in contacts):
        return run(edges, 1.0)
    m = edges
    while True:
        inner = run(m, 1.0)
        if inner.closure:
            return inner
        outer = run(m, 1.0 / np.cos(np.pi / m))
        if not outer.closure:
            return replace(outer, margin=0.0)
        if m >= 1024:
            return inner  # undecided at 1024 edges: the origin is on the boundary to 1e-5
        m *= 2


def form_closure(
    contacts: list[GraspContact], *, method: str = "lp", center: FloatArray | None = None
) -> ClosureResult:
    """First-order form closure: force closure with the contacts taken frictionless."""
    frictionless = [replace(c, type=ContactType.FRICTIONLESS) for c in check_contacts(contacts)]
    return force_closure(frictionless, method=method, center=center)
