"""Ferrari-Canny epsilon (L1): a certified unmerged convex hull, or facets in closed form.

The L1 grasp wrench space is ``P = conv{w_k}`` and its epsilon is the distance from the origin
to the nearest facet plane: ``eps = min_j b_j`` over the facets ``a_j^T w <= b_j``
(``|a_j| = 1``), 0 when the origin is not strictly inside. Primitive wrenches are degenerate
by construction (the ``m`` edges of one friction cone are coplanar), and qhull's default
handling of that, merging facets ("Qx"), is most of its work. Here the hull is built without
merging (qhull "Q0") and its output is certified instead:

1. every facet plane has every input point on its inner side (to ``1e-12`` of the largest
   entry): then each ``b_j >= eps``, because the ball of radius ``eps`` lies inside ``P``;
2. the facets form a closed surface (every facet has all its neighbours): with 1., it is the
   boundary of ``P``, so the ray from the origin to the nearest boundary point crosses one of
   them, whose plane then has ``b_j <= eps``.

So ``min_j b_j = eps``. When either check fails, or qhull reports a precision error, the hull
is rebuilt with qhull's merging options (the exact default). A grasp out of closure is often
recognized before any hull: a direction ``c`` with ``c^T w_k >= 0`` for every ``k`` (the
mean wrench, the coordinate axes) proves it (Gordan's alternative).

Compiled path: when taskspace's compiled kernels are built, 6-D wrench sets are first given to
``_planning_kernel.epsilon_l1`` (src/taskspace/_native/grasp_epsilon.cpp), the same column
generation as :func:`_epsilon_generated` on its own simplicial hull (an EPA-style expansion from
a simplex, one support point per step, no qhull), all grasps of a batch in one call, with the
same certificate (closed surface, every point of the subset inside every facet plane; the
nearest facet supports every wrench to :data:`SUPPORT_TOLERANCE`). A grasp it cannot certify
(flat, too thin a facet, a failed certificate) is answered by the qhull path below.

For two soft fingers and for three point contacts, :func:`grasp_epsilon_batch` needs no hull:
each contact's wrenches span a small polytope in a low-dimensional flat (a bipyramid, a
polygon), every facet of ``P`` is spanned by faces of these, and the few candidate planes of
each grasp are solved in closed form for many grasps at once.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError

from taskspace._native import planning_kernel
from taskspace._validation import as_float_array, check_positive
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.grasping.contact import check_edges, nonnegative

FloatArray = npt.NDArray[np.float64]

MARGIN_TOLERANCE = 1e-9
"""Epsilon values at or below this times the largest ``|w|`` entry are 0 (not in closure).

The origin on the hull's boundary (a grasp exactly at the limit of closure, e.g. three
contacts whose wrenches span a face through the origin) gives offsets of roundoff size
(1e-17-1e-15) of either sign; :func:`~taskspace.grasping.closure_hull` uses the same tolerance.
"""

CERTIFICATE_TOLERANCE = 1e-12
"""Largest violation of a facet plane by an input point (relative to the largest entry)
accepted from the unmerged hull; qhull's roundoff is about 1e-15."""


def _separated(W: FloatArray) -> bool:
    """True when a cheap direction proves that the origin is not strictly inside.

    ``W`` is scaled to a largest entry of 1. A unit ``c`` with ``min_k c^T w_k >= -t`` bounds
    the epsilon by ``t`` (the support of ``conv W`` along ``-c``), so ``t = MARGIN_TOLERANCE``
    gives the same answer (0) as the hull.
    """
    t = -MARGIN_TOLERANCE
    if np.any(W.min(axis=0) >= t) or np.any(W.max(axis=0) <= -t):  # +-coordinate axes
        return True
    c = W.sum(axis=0)
    norm = float(np.linalg.norm(c))
    return norm > 0 and float((W @ c).min()) >= t * norm


def _certified_offsets(W: FloatArray) -> FloatArray | None:
    """Facet offsets ``b_j`` of the unmerged hull when certified (see the module), else None."""
    try:
        hull = ConvexHull(W, qhull_options="Q0")
    except (QhullError, ValueError):
        return None
    return -hull.equations[:, -1] if _hull_certified(hull, W) else None


def _hull_certified(hull: ConvexHull, points: FloatArray) -> bool:
    """The facets of ``hull`` close up and each of ``points`` is inside every facet plane."""
    E = hull.equations
    if np.any(hull.neighbors < 0):
        return False
    violation = float((points @ E[:, :-1].T + E[:, -1]).max())
    return violation <= CERTIFICATE_TOLERANCE


def _merged_offsets(W: FloatArray) -> FloatArray | None:
    try:
        return -ConvexHull(W).equations[:, -1]
    except (QhullError, ValueError):
        return None  # flat: the origin is not strictly inside


SUPPORT_TOLERANCE = 1e-12
"""Column generation stops when the support of every wrench along the nearest facet's normal
exceeds that facet's offset by at most this (relative to the largest entry): the value
returned is then below the true epsilon by at most this much."""

GENERATION_MIN_WRENCHES = 20
"""Wrench sets at least this large use :func:`_epsilon_generated` (a hull of a subset);
smaller ones build the hull of all wrenches at once (as cheap, fewer steps)."""

_FACETS_PER_STEP = 5
"""Facets (the nearest ones) whose support points are added per column-generation step."""


def _epsilon_generated(W: FloatArray) -> float | None:
    """Epsilon of ``W`` (largest entry 1) from the hull of a growing subset; None when unsure.

    ``S`` starts as the support points of ``W`` along the ``2 d`` coordinate directions and
    grows (qhull incremental, unmerged) by the support points ``argmax_i u . w_i`` of the
    nearest facets of ``conv S`` that ``W`` violates. It stops when the nearest facet
    ``(u, b)`` supports all of ``W`` (``max_i u . w_i <= b + SUPPORT_TOLERANCE``); the hull of
    ``S`` is then certified as in :func:`_certified_offsets`, so ``b = eps(conv S)``. Since
    ``conv S`` is inside ``P = conv W``, ``eps(P) >= b``; since the ball of radius ``eps(P)``
    is inside ``P``, ``eps(P) <= h_P(u) <= b + SUPPORT_TOLERANCE``. Only the facets near the
    origin are ever built: a subset of about half the wrenches for 5 contacts.
    """
    k, d = W.shape
    start = np.unique(np.argmax(np.hstack([W, -W]), axis=0))
    if len(start) <= d:
        return None
    chosen = np.zeros(k, dtype=bool)
    chosen[start] = True
    try:
        hull = ConvexHull(W[start], incremental=True, qhull_options="Q0")
    except (QhullError, ValueError):
        return None
    try:
        for _ in range(k):
            E = hull.equations
            offsets = -E[:, -1]
            near = np.argsort(offsets)[:_FACETS_PER_STEP]
            support = W @ E[near, :-1].T  # (k, facets)
            best = np.argmax(support, axis=0)
            excess = support[best, np.arange(len(near))] - offsets[near]
            if excess[0] <= SUPPORT_TOLERANCE:
                return float(offsets[near[0]]) if _hull_certified(hull, hull.points) else None
            new = np.unique(best[excess > SUPPORT_TOLERANCE])
            new = new[~chosen[new]]
            if len(new) == 0:  # a chosen wrench outside a facet of conv S: not certified
                return None
            chosen[new] = True
            hull.add_points(W[new])
    except (QhullError, ValueError):
        return None
    finally:
        hull.close()
    return None


def _epsilon_normalized(W: FloatArray) -> float:
    """Epsilon of ``W`` scaled to a largest entry of 1 (no validation)."""
    k, d = W.shape
    if k <= d or _separated(W):
        return 0.0
    if k >= GENERATION_MIN_WRENCHES:
        margin = _epsilon_generated(W)
        if margin is not None:
            return margin if margin > MARGIN_TOLERANCE else 0.0
    return _epsilon_full(W)


def _epsilon_full(W: FloatArray) -> float:
    """Epsilon of ``W`` (largest entry 1, not separated) from the hull of all of ``W``."""
    offsets = _certified_offsets(W)
    if offsets is None:
        offsets = _merged_offsets(W)
        if offsets is None:
            return 0.0
    margin = float(offsets.min())
    return margin if margin > MARGIN_TOLERANCE else 0.0


def _compiled(W: FloatArray) -> tuple[FloatArray, npt.NDArray[np.bool_]] | None:
    """Epsilons of ``(B, K, 6)`` wrenches from the compiled kernel and which it certified.

    None when the kernel is not built (or ``d != 6``); the grasps not certified (``False``)
    must be answered by the qhull path.
    """
    if W.shape[2] != 6 or W.shape[1] >= 65000:
        return None
    kernel = planning_kernel()
    if kernel is None or not hasattr(kernel, "epsilon_l1"):
        return None
    eps, status, _ = kernel.epsilon_l1(
        np.ascontiguousarray(W), SUPPORT_TOLERANCE, CERTIFICATE_TOLERANCE, MARGIN_TOLERANCE
    )
    return eps, status > 0


LINF_MAX_STEPS = 20_000
"""Most support points the compiled L-infinity epsilon adds before it gives up (then the hull
of the Minkowski sum is built, when small enough)."""


def epsilon_linf_compiled(W: FloatArray, owner: npt.NDArray[np.int64]) -> float | None:
    """L-infinity epsilon of validated ``(K, 6)`` wrenches from the compiled kernel.

    The L-infinity wrench space ``sum_i conv({0} u W_i)`` is only queried through its support
    ``h(u) = sum_i max(0, max_{w in W_i} u . w)``: the same expansion and certificate as the
    L1 epsilon, on support points of the sum (never its vertices, whose number grows as the
    product of the contacts'). Tolerances relative to the largest wrench entry. None when the
    kernel is not built, ``d != 6``, or it could not certify (the caller builds the hull).

    Args:
        W: wrenches ``(K, 6)``, finite.
        owner: ``(K,)`` contact of each row (any ints; relabelled here).
    """
    if W.ndim != 2 or W.shape[1] != 6 or len(W) == 0:
        return None
    kernel = planning_kernel()
    if kernel is None or not hasattr(kernel, "epsilon_linf"):
        return None
    labels = np.unique(owner, return_inverse=True)[1].astype(np.int32)
    eps, status, _ = kernel.epsilon_linf(
        np.ascontiguousarray(W[None], dtype=float),
        labels,
        SUPPORT_TOLERANCE,
        CERTIFICATE_TOLERANCE,
        MARGIN_TOLERANCE,
        LINF_MAX_STEPS,
    )
    return float(eps[0]) if status[0] > 0 else None


def _check_batch(W: object, name: str) -> FloatArray:
    arr = as_float_array(W, name)
    if arr.ndim != 3 or 0 in arr.shape or arr.shape[2] < 2:
        raise InvalidInputError(
            f"{name} must be a (B, K, d) array: B grasps of K wrenches with d >= 2 components "
            f"(one a row, as primitive_wrenches gives), got shape {arr.shape}"
        )
    bad = ~np.all(np.isfinite(arr), axis=(1, 2))
    if np.any(bad):
        raise InvalidInputError(
            f"{name} must be finite (no NaN or inf entries); grasps "
            f"{np.flatnonzero(bad)[:10].tolist()} are not"
        )
    return arr


def epsilon_l1_fast(W: FloatArray, *, native: bool = True) -> float:
    """Ferrari-Canny epsilon of the L1 wrench space of primitive wrenches ``W`` (rows).

    ``eps = min_j b_j`` over the facets ``a_j^T w <= b_j`` of ``conv W``; 0 when the origin
    is not strictly inside (margins within :data:`MARGIN_TOLERANCE` of the largest entry
    count as 0).

    Args:
        W: primitive wrenches, shape ``(K, d)`` with ``d >= 2`` (finite).
        native: use the compiled kernel for 6-D wrenches when it is built (same values to
            rounding; what it cannot certify goes to qhull); False: qhull only.

    Raises:
        InvalidInputError: when ``W`` is not a finite ``(K, d)`` array with ``d >= 2``.
    """
    arr = as_float_array(W, "W")
    if arr.ndim != 2 or 0 in arr.shape or arr.shape[1] < 2:
        raise InvalidInputError(
            "W must be a (K, d) array of wrenches, one a row (K >= 1, d >= 2 components for "
            f"a hull), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError("W must be finite (no NaN or inf entries)")
    if native:
        compiled = _compiled(arr[None])
        if compiled is not None and compiled[1][0]:
            return float(compiled[0][0])
    scale = float(np.abs(arr).max())
    return _epsilon_normalized(arr / scale) * scale if scale > 0 else 0.0


def epsilon_l1_batch(W: FloatArray, *, native: bool = True) -> FloatArray:
    """Epsilon (L1) of many grasps with the same number of wrenches.

    Args:
        W: ``(B, K, d)``: grasp ``b``'s primitive wrenches are ``W[b]`` (rows).
        native: score 6-D wrenches with the compiled kernel when it is built, all grasps in
            one call (what it cannot certify goes to qhull); False: qhull only.

    Returns:
        ``(B,)`` epsilons, each equal to :func:`epsilon_l1_fast` of ``W[b]``.
    """
    arr = _check_batch(W, "W")
    scale = np.abs(arr).max(axis=(1, 2))
    out = np.zeros(len(arr))
    todo = scale > 0
    compiled = _compiled(arr) if native else None
    if compiled is not None:
        out, done = compiled
        todo &= ~done
    for b in np.flatnonzero(todo):
        out[b] = _epsilon_normalized(arr[b] / scale[b]) * scale[b]
    return out


def _contact_frames(normals: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Tangents ``t1, t2`` of :func:`~taskspace.grasping.contact_frame`, row by row."""
    helper = np.where(np.abs(normals[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    t1 = np.cross(helper, normals)
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    return t1, np.cross(normals, t1)


def primitive_wrenches_batch(
    positions: FloatArray,
    normals: FloatArray,
    *,
    mu: float = 0.5,
    edges: int = 8,
    torsion: float = 0.0,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
) -> FloatArray:
    """:func:`~taskspace.grasping.primitive_wrenches` of ``B`` grasps of ``k`` contacts at once.

    Every contact is a point with Coulomb friction ``mu`` (soft finger when ``torsion > 0``:
    two more rows ``(n, +-torsion n)``), in the order and frames of ``primitive_wrenches``.

    Args:
        positions: ``(B, k, 3)`` contact points [m].
        normals: ``(B, k, 3)`` inward normals (normalized here).
        mu: friction coefficient.
        edges: edges of each linearized friction cone.
        torsion: soft-finger torsional coefficient [m] (0: point contacts).
        center: moment reference point [m], ``(3,)`` or ``(B, 3)`` (default: the origin).
        torque_scale: ``rho`` [m] (default: per grasp, the largest distance of a contact from
            the center, 1 when all are on it).

    Returns:
        ``(B, k * (edges + 2 [soft]), 6)`` wrenches ``(f, ((p - c) x f + tau_n n) / rho)``.
    """
    n, r, rho, mu, edges, torsion = _contact_inputs(
        positions, normals, mu, edges, torsion, center, torque_scale
    )
    return _wrenches_of(n, r, rho, mu, edges, torsion)


def _contact_inputs(
    positions: object,
    normals: object,
    mu: object,
    edges: object,
    torsion: object,
    center: object,
    torque_scale: object,
) -> tuple[FloatArray, FloatArray, FloatArray, float, int, float]:
    """Validated unit normals, lever arms ``p - c``, torque scales ``(B,)`` and settings."""
    p = as_float_array(positions, "positions")
    n = as_float_array(normals, "normals")
    if p.ndim != 3 or p.shape[2] != 3 or 0 in p.shape:
        raise InvalidInputError(
            f"positions must be a (B, k, 3) array (B grasps of k contacts), got shape {p.shape}"
        )
    if n.shape != p.shape:
        raise ShapeError("normals", p.shape, n.shape)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
        raise InvalidInputError("contact positions and normals must be finite")
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise InvalidInputError("contact normals must not be zero")
    n = n / norm
    mu = nonnegative(mu, "mu")
    torsion = nonnegative(torsion, "torsion")
    edges = check_edges(edges)
    c = np.zeros(3) if center is None else as_float_array(center, "center")
    if c.shape not in ((3,), (len(p), 3)) or not np.all(np.isfinite(c)):
        raise InvalidInputError(
            f"center must be a finite (3,) or ({len(p)}, 3) array, got shape {c.shape}"
        )
    r = p - (c[:, None, :] if c.ndim == 2 else c)
    if torque_scale is None:
        rho = np.hypot.reduce(r, axis=-1).max(axis=1)  # no overflow of |r|^2 past 1e154
        rho = np.where(rho > 1e-12, rho, 1.0)
    elif isinstance(torque_scale, (bool, np.bool_)):
        raise InvalidInputError(f"torque_scale must be a length [m] > 0, got {torque_scale!r}")
    else:
        rho = np.full(len(p), check_positive(torque_scale, "torque_scale [m]"))
    return n, r, rho, mu, edges, torsion


def _wrenches_of(
    n: FloatArray, r: FloatArray, rho: FloatArray, mu: float, edges: int, torsion: float
) -> FloatArray:
    """Primitive wrenches ``(B, k * rows, 6)`` of validated contact data."""
    t1, t2 = _contact_frames(n)
    theta = 2.0 * np.pi * np.arange(edges) / edges
    # forces (B, k, m, 3): n + mu (cos t1 + sin t2)
    forces = n[:, :, None, :] + mu * (
        np.cos(theta)[None, None, :, None] * t1[:, :, None, :]
        + np.sin(theta)[None, None, :, None] * t2[:, :, None, :]
    )
    # moments of r / rho (not r x f / rho: it would overflow for huge r and a huge rho)
    rs = r / rho[:, None, None]
    moments = np.cross(rs[:, :, None, :], forces)
    if torsion > 0:
        both = np.stack([n, n], axis=2)
        twist = np.array([torsion, -torsion])[None, None, :, None] * n[:, :, None, :]
        forces = np.concatenate([forces, both], axis=2)
        twist = twist / rho[:, None, None, None]
        moments = np.concatenate([moments, np.cross(rs[:, :, None, :], both) + twist], axis=2)
    W = np.concatenate([forces, moments], axis=3)
    return W.reshape(len(n), -1, 6)


def grasp_epsilon_batch(
    positions: FloatArray,
    normals: FloatArray,
    *,
    mu: float = 0.5,
    edges: int = 8,
    torsion: float = 0.0,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
    native: bool = True,
) -> FloatArray:
    """Epsilon (L1) of ``B`` grasps of ``k`` friction contacts, ``(B,)`` (0 out of closure).

    The arguments are those of :func:`primitive_wrenches_batch`. With the compiled kernel
    built (and ``native``), all grasps are scored by it in one call; the grasps it cannot
    certify, and all of them without it, take the NumPy paths: two soft fingers (``k = 2``,
    ``torsion > 0``: parallel-jaw grasps) and three point contacts (``k = 3``, no torsion, at
    most 16 edges) without a hull, all at once, by enumerating their facets in closed form (a
    grasp where that is degenerate falls back to its hull); other grasps build one certified
    hull each.
    """
    n, r, rho, mu, edges, torsion = _contact_inputs(
        positions, normals, mu, edges, torsion, center, torque_scale
    )
    W = _wrenches_of(n, r, rho, mu, edges, torsion)
    compiled = _compiled(W) if native else None
    if compiled is None:
        return _closed_forms(W, n, r, rho, mu, edges, torsion)
    out, done = compiled
    rest = np.flatnonzero(~done)
    if len(rest):
        out[rest] = _closed_forms(W[rest], n[rest], r[rest], rho[rest], mu, edges, torsion)
    return out


def _closed_forms(
    W: FloatArray,
    n: FloatArray,
    r: FloatArray,
    rho: FloatArray,
    mu: float,
    edges: int,
    torsion: float,
) -> FloatArray:
    """The NumPy path of :func:`grasp_epsilon_batch` (closed forms, else qhull)."""
    k = n.shape[1]
    if k == 2 and torsion > 0 and mu > 0:
        chunk = _CHUNK
    elif k == 3 and torsion == 0 and mu > 0 and edges <= 16:
        chunk = max(1, _CHUNK * 512 // edges**3)
    else:
        return epsilon_l1_batch(W, native=False)
    out = np.empty(len(W))
    for start in range(0, len(W), chunk):
        part = slice(start, start + chunk)
        if k == 2:
            out[part] = _two_soft_fingers(W[part], n[part], r[part], rho[part], mu, torsion, edges)
        else:
            out[part] = _three_point_contacts(W[part], n[part], r[part], rho[part], mu, edges)
    rest = np.flatnonzero(np.isnan(out))
    if len(rest):
        out[rest] = epsilon_l1_batch(W[rest], native=False)
    return out


_CHUNK = 128
"""Grasps per vectorized block of :func:`_two_soft_fingers` (about 0.3 MB per grasp)."""


def _bipyramid_faces(
    mu: float, torsion: float, edges: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Faces of one soft-finger contact's wrench polytope, in its local coordinates.

    A contact's primitive wrenches are ``L z`` with ``z = (x, y, 1, tau)``: the cone edges at
    ``(mu cos, mu sin, 1, 0)`` and the torsion edges at ``(0, 0, 1, +-torsion)``, a bipyramid
    over an ``edges``-gon. Returns the triangles as affine functions ``c . z`` vanishing on
    them and negative inside, ``(2 m, 4)``, and for each of its ``3 m`` edges a basis of the
    ``psi`` with ``psi . z = 0`` at both ends, ``(3 m, 2, 4)``, and its vertices ``z``,
    ``(m + 2, 4)``.
    """
    theta = 2.0 * np.pi * np.arange(edges) / edges
    ring = np.column_stack([mu * np.cos(theta), mu * np.sin(theta), np.zeros(edges)])
    apexes = np.array([[0.0, 0.0, torsion], [0.0, 0.0, -torsion]])
    nxt = np.roll(np.arange(edges), -1)
    triangles = []
    ends = []
    for apex in apexes:
        c = np.cross(ring - apex, ring[nxt] - apex)
        d = c @ apex
        flip = np.where(d < 0, -1.0, 1.0)  # outward: c . u <= d on the bipyramid (0 inside)
        c, d = c * flip[:, None], d * flip
        triangles.append(np.column_stack([c[:, 0], c[:, 1], -d, c[:, 2]]))
        ends.append(np.stack([ring, np.repeat(apex[None], edges, axis=0)], axis=1))
    ends.append(np.stack([ring, ring[nxt]], axis=1))
    pairs = np.concatenate(ends)  # (3 m, 2, 3) local (x, y, tau)
    z = np.stack([pairs[..., 0], pairs[..., 1], np.ones(pairs.shape[:2]), pairs[..., 2]], -1)
    psi = np.linalg.svd(z)[2][:, 2:, :]  # null space of the two end points, (3 m, 2, 4)
    vertices = np.vstack([ring, apexes])
    local = np.column_stack([vertices[:, :2], np.ones(len(vertices)), vertices[:, 2]])
    return np.concatenate(triangles), psi, local


def _cross_rows(M: FloatArray) -> FloatArray:
    """Unit null vector of each ``(..., 2, 3)`` matrix (zero when its rank is below 2)."""
    (x0, y0, z0), (x1, y1, z1) = np.moveaxis(M[..., 0, :], -1, 0), np.moveaxis(M[..., 1, :], -1, 0)
    x = np.stack([y0 * z1 - z0 * y1, z0 * x1 - x0 * z1, x0 * y1 - y0 * x1], axis=-1)
    norm = np.sqrt(x[..., 0] ** 2 + x[..., 1] ** 2 + x[..., 2] ** 2)[..., None]
    scale = np.sqrt((x0**2 + y0**2 + z0**2) * (x1**2 + y1**2 + z1**2))[..., None]
    return np.where(norm > 1e-12 * scale, x / np.where(norm > 0, norm, 1.0), 0.0)


def _two_soft_fingers(
    W: FloatArray,
    normals: FloatArray,
    r: FloatArray,
    rho: FloatArray,
    mu: float,
    torsion: float,
    edges: int,
) -> FloatArray:
    """Epsilon of two soft-finger grasps from their facets, enumerated in closed form.

    With ``A``, ``B`` the two contacts' bipyramids (each in a 3-flat), every facet of
    ``conv(A u B)`` is ``conv(F_A u F_B)`` with faces whose affine hulls add up to 5
    dimensions: two triangles, or a whole bipyramid and an edge of the other. For each such
    pair the plane ``a^T w = b`` is the 1-D solution of a 2 x 3 system: writing
    ``alpha = L_A^T a``, ``beta = L_B^T a``, the pair fixes ``(alpha, beta)`` up to 3
    parameters and ``(alpha, beta)`` must lie in the range of ``[L_A L_B]^T`` (2 equations).
    The candidates whose plane has every wrench on one side are the facets; epsilon is their
    least offset. NaN for a grasp whose ``[L_A L_B]`` has rank below 6 (the caller then
    builds the hull).
    """
    B = len(W)
    t1, t2 = _contact_frames(normals)
    n = normals
    cols = [
        np.concatenate([t1, np.cross(r, t1) / rho[:, None, None]], axis=-1),
        np.concatenate([t2, np.cross(r, t2) / rho[:, None, None]], axis=-1),
        np.concatenate([n, np.cross(r, n) / rho[:, None, None]], axis=-1),
        np.concatenate([np.zeros_like(n), n / rho[:, None, None]], axis=-1),
    ]
    L_local = np.stack(cols, axis=-1)  # (B, 2, 6, 4)
    L = np.concatenate([L_local[:, 0], L_local[:, 1]], axis=-1)  # (B, 6, 8)
    U, S, Vt = np.linalg.svd(L)
    good = S[:, -1] > 1e-9 * S[:, 0]
    N = np.swapaxes(Vt[:, 6:, :], 1, 2)  # (B, 8, 2): (alpha; beta) must be orthogonal to it
    Q = U @ (Vt[:, :6, :] / np.where(S > 0, S, 1.0)[:, :, None])  # a = Q (alpha; beta)
    NA, NB = N[:, :4, :], N[:, 4:, :]
    g = NA[:, 2, :] + NB[:, 2, :]  # (B, 2): coefficient of b
    tri, psi, local = _bipyramid_faces(mu, torsion, edges)
    scale = np.abs(W).max(axis=(1, 2))
    tol = 1e-10 * scale
    e3 = np.array([0.0, 0.0, 1.0, 0.0])
    QA, QB = Q[:, :, :4], Q[:, :, 4:]
    h = QA[:, :, 2] + QB[:, :, 2]  # (B, 6): a's part from b
    # Two triangles T (of A), T' (of B): alpha = s c_T + b e3, beta = s' c_T' + b e3 and
    # N^T (alpha; beta) = s p_T + s' q_T' + b g = 0, so (s, s', b) = (p_T, q_T', g) rows
    # crossed: s depends on T' only, s' on T only.
    p = tri @ NA  # (B, T, 2)
    q = tri @ NB
    g0, g1 = g[:, None, None, 0], g[:, None, None, 1]
    s_ = q[:, None, :, 0] * g1 - g0 * q[:, None, :, 1]  # (B, 1, T')
    s2 = g0 * p[:, :, None, 1] - p[:, :, None, 0] * g1  # (B, T, 1)
    bb = p[:, :, None, 0] * q[:, None, :, 1] - q[:, None, :, 0] * p[:, :, None, 1]  # (B, T, T')
    rows = np.sqrt(
        (p[:, :, None, 0] ** 2 + q[:, None, :, 0] ** 2 + g0**2)
        * (p[:, :, None, 1] ** 2 + q[:, None, :, 1] ** 2 + g1**2)
    )
    u = np.swapaxes(QA @ tri.T, 1, 2)  # (B, T, 6): Q_A c_T
    v = np.swapaxes(QB @ tri.T, 1, 2)  # (B, T', 6)
    # a = s u_T + s' v_T' + b h. On A's wrenches a . w - b = s c_T . z <= 0 exactly when
    # s >= 0 (c_T is negative inside A), on B's when s' >= 0: the plane supports every
    # wrench when s and s' have the same sign, with offset b / |a| (or -b / |a| when both
    # are negative). No wrench needs to be tested.
    uu = np.einsum("btd,btd->bt", u, u)
    vv = np.einsum("btd,btd->bt", v, v)
    hh = np.einsum("bd,bd->b", h, h)[:, None, None]
    uv = u @ np.swapaxes(v, 1, 2)  # (B, T, T')
    uh = u @ h[:, :, None]  # (B, T, 1)
    vh = v @ h[:, :, None]  # (B, T', 1)
    norm2 = (
        s_**2 * uu[:, :, None]
        + s2**2 * vv[:, None, :]
        + bb**2 * hh
        + 2 * s_ * s2 * uv
        + 2 * s_ * bb * uh
        + 2 * s2 * bb * np.swapaxes(vh, 1, 2)
    )
    norm = np.sqrt(np.maximum(norm2, 0.0))
    ok = (np.sqrt(s_**2 + s2**2 + bb**2) > 1e-12 * rows) & (norm > 0)
    norm = np.where(ok, norm, 1.0)
    upper = np.where(ok & (s_ >= 0) & (s2 >= 0), bb / norm, np.inf)
    lower = np.where(ok & (s_ <= 0) & (s2 <= 0), -bb / norm, np.inf)
    best = [np.minimum(upper, lower).reshape(B, -1).min(axis=1)]
    # A whole bipyramid and an edge of the other: alpha = b e3, beta = b e3 + psi sigma
    # (psi . z = 0 at the edge's ends). On the whole one a . w - b = 0; on the other it is
    # (psi sigma) . z, tested at its 2 m + 2 vertices (local coordinates, no wrench needed).
    psi_z = psi @ local.T  # (E, 2, V)
    for whole, other in ((0, 1), (1, 0)):
        No = (NA, NB)[other]
        cols_psi = np.tensordot(No, psi, axes=([1], [2])).transpose(0, 2, 1, 3)  # (B, E, 2, 2)
        E = psi.shape[0]
        M2 = np.concatenate([np.broadcast_to(g[:, None, :, None], (B, E, 2, 1)), cols_psi], -1)
        sol2 = _cross_rows(M2)  # (b, sigma1, sigma2)
        b2 = sol2[..., 0]
        sig1, sig2 = sol2[..., 1:2], sol2[..., 2:3]  # (B, E, 1)
        full = b2[..., None] * e3
        part = full + sig1 * psi[:, 0] + sig2 * psi[:, 1]
        pair = (full, part) if whole == 0 else (part, full)
        a2 = np.concatenate(pair, axis=-1) @ np.swapaxes(Q, 1, 2)  # (B, E, 6)
        n2 = np.linalg.norm(a2, axis=-1)
        ok2 = n2 > 1e-9
        n2 = np.where(ok2, n2, 1.0)
        side2 = sig1 * psi_z[:, 0] + sig2 * psi_z[:, 1]  # (B, E, V)
        lim2 = tol[:, None] * n2
        up2 = np.where(ok2 & (side2.max(axis=-1) <= lim2), b2 / n2, np.inf)
        lo2 = np.where(ok2 & (side2.min(axis=-1) >= -lim2), -b2 / n2, np.inf)
        best.append(np.minimum(up2, lo2).min(axis=1))
    eps = np.min(best, axis=0)
    out = np.where(eps > MARGIN_TOLERANCE * scale, eps, 0.0)
    return np.where(good & np.isfinite(eps), out, np.nan)


def _cross3(u: FloatArray, v: FloatArray) -> FloatArray:
    """``u x v`` along the last axis (broadcast), without ``np.cross``'s axis shuffling."""
    u0, u1, u2 = u[..., 0], u[..., 1], u[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0], axis=-1)


def _det3(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
    """``det [a b c]`` of 3-vectors along the last axis (broadcast)."""
    return (
        a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
        - a[..., 1] * (b[..., 0] * c[..., 2] - b[..., 2] * c[..., 0])
        + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0])
    )


def _null4(c1: FloatArray, c2: FloatArray, c3: FloatArray, c4: FloatArray) -> FloatArray:
    """Null vector of the 3 x 4 matrices ``[c1 c2 c3 c4]`` (columns, broadcast), by minors."""
    c1, c2, c3, c4 = np.broadcast_arrays(c1, c2, c3, c4)
    return np.stack(
        [_det3(c2, c3, c4), -_det3(c1, c3, c4), _det3(c1, c2, c4), -_det3(c1, c2, c3)], axis=-1
    )


def _fold(
    best: FloatArray,
    x0: FloatArray,
    x1: FloatArray,
    x2: FloatArray,
    x3: FloatArray,
    norm2: FloatArray,
    col_scale: FloatArray,
) -> npt.NDArray[np.bool_]:
    """Fold candidate planes into ``best`` (per grasp, in place); the grasps with a degenerate one.

    A candidate is ``x = (b, s1, s2, s3)`` (null vector of its 3 x 4 system) with
    ``|a|^2 = norm2``; it supports every wrench with offset ``b / |a|`` when the ``s`` are all
    >= 0, ``-b / |a|`` when all <= 0 (to ``1e-12 |x|``).
    """
    B = len(best)
    xnorm = np.sqrt(x0**2 + x1**2 + x2**2 + x3**2)
    shape = (B,) + (1,) * (xnorm.ndim - 1)
    degenerate = (xnorm <= 1e-9 * col_scale.reshape(shape) ** 3).reshape(B, -1).any(axis=1)
    anorm = np.sqrt(np.maximum(norm2, 0.0))
    anorm = np.where(anorm > 0, anorm, 1.0)
    tol = 1e-12 * xnorm
    up = (x1 >= -tol) & (x2 >= -tol) & (x3 >= -tol)
    lo = (x1 <= tol) & (x2 <= tol) & (x3 <= tol)
    cand = np.where(up, x0 / anorm, np.where(lo, -x0 / anorm, np.inf))
    np.minimum(best, cand.reshape(B, -1).min(axis=1), out=best)
    return np.asarray(degenerate, dtype=bool)


def _three_point_contacts(
    W: FloatArray, normals: FloatArray, r: FloatArray, rho: FloatArray, mu: float, edges: int
) -> FloatArray:
    """Epsilon of three point contacts with friction from their facets, in closed form.

    Each contact's wrenches are ``L_i z`` with ``z = (x, y, 1)`` on an ``m``-gon (a 2-flat).
    A facet meets each polygon in a face (vertex, edge, whole polygon: 1, 2, 3 points); its
    plane is fixed by a choice of faces whose point counts are (3, 3, 0), (3, 2, 1) or
    (2, 2, 2). With ``alpha_i = L_i^T a = b e3 + sum sigma psi`` (``psi`` the outward lines of
    the polygon's edges through the chosen face) and ``sum_i N_i^T alpha_i = 0`` (``N`` the
    kernel of ``[L_1 L_2 L_3]``), each choice is a 3 x 4 system whose null vector gives
    ``(b, sigma)``; the plane supports every wrench exactly when the sigmas share one sign
    (the free polygon of (3, 3, 0) is tested at its vertices). Every such choice made of
    affinely independent points, the enumeration meets every facet; a grasp with a degenerate
    choice (or rank ``[L_1 L_2 L_3]`` below 6) gives NaN and the caller builds its hull.
    """
    B, m = len(W), edges
    t1, t2 = _contact_frames(normals)
    cols = [
        np.concatenate([t, np.cross(r, t) / rho[:, None, None]], axis=-1) for t in (t1, t2, normals)
    ]
    L_local = np.stack(cols, axis=-1)  # (B, 3, 6, 3)
    L = np.concatenate([L_local[:, 0], L_local[:, 1], L_local[:, 2]], axis=-1)  # (B, 6, 9)
    U, S, Vt = np.linalg.svd(L)
    good = S[:, -1] > 1e-9 * S[:, 0]
    N = np.swapaxes(Vt[:, 6:, :], 1, 2)  # (B, 9, 3)
    Q = U @ (Vt[:, :6, :] / np.where(S > 0, S, 1.0)[:, :, None])  # (B, 6, 9)
    theta = 2.0 * np.pi * np.arange(m) / m
    V = np.column_stack([mu * np.cos(theta), mu * np.sin(theta), np.ones(m)])  # (m, 3)
    lines = np.cross(V, np.roll(V, -1, axis=0))  # edge j: V_j -> V_j+1, psi . z = 0 on it
    lines *= np.where(lines[:, 2] > 0, -1.0, 1.0)[:, None]  # negative at the centre: outward
    Ni = [N[:, 3 * i : 3 * i + 3, :] for i in range(3)]  # (B, 3, 3): alpha_i -> constraint
    Qi = [Q[:, :, 3 * i : 3 * i + 3] for i in range(3)]  # (B, 6, 3): alpha_i -> a
    g = Ni[0][:, 2, :] + Ni[1][:, 2, :] + Ni[2][:, 2, :]  # (B, 3): coefficient of b
    h = Qi[0][:, :, 2] + Qi[1][:, :, 2] + Qi[2][:, :, 2]  # (B, 6)
    P = [lines @ n_ for n_ in Ni]  # (B, m, 3): N_i^T psi_e
    Ua = [np.swapaxes(q_ @ lines.T, 1, 2) for q_ in Qi]  # (B, m, 6): Q_i psi_e
    scale = np.abs(W).max(axis=(1, 2))
    best = np.full(B, np.inf)
    degenerate = ~good
    col_scale = np.sqrt(
        np.max([np.sum(x**2, axis=-1).max(axis=-1) for x in P] + [np.sum(g**2, axis=-1)], axis=0)
    )  # (B,)

    def offsets(x: FloatArray, a: FloatArray, signs: FloatArray, c: FloatArray) -> None:
        """Fold the candidates ``x = (b, sigmas)`` with normals ``a`` into ``best``."""
        nonlocal degenerate
        flat = x.reshape(B, -1, x.shape[-1])
        small = np.linalg.norm(flat, axis=-1) <= 1e-9 * c[:, None] ** 3
        degenerate = degenerate | small.any(axis=1)
        norm = np.linalg.norm(a.reshape(B, -1, 6), axis=-1)
        norm = np.where(norm > 0, norm, 1.0)
        b = flat[..., 0] / norm
        s = signs.reshape(B, flat.shape[1], -1)
        tol = 1e-12 * np.linalg.norm(flat, axis=-1)
        upper = np.where(np.all(s >= -tol[..., None], axis=-1), b, np.inf)
        lower = np.where(np.all(s <= tol[..., None], axis=-1), -b, np.inf)
        np.minimum(best, np.minimum(upper, lower).min(axis=1), out=best)

    # (2, 2, 2): an edge of every polygon; x = (b, sigma_1, sigma_2, sigma_3) by minors of
    # [g, P_1[e1], P_2[e2], P_3[e3]] (only b depends on all three edges), |a| by Gram terms.
    c12 = _cross3(P[1][:, :, None, :], P[2][:, None, :, :]).reshape(B, m * m, 3)  # e2, e3
    c02 = _cross3(P[0][:, :, None, :], P[2][:, None, :, :]).reshape(B, m * m, 3)  # e1, e3
    c01 = _cross3(P[0][:, :, None, :], P[1][:, None, :, :]).reshape(B, m * m, 3)  # e1, e2
    gc = g[:, :, None]
    x0 = (P[0] @ np.swapaxes(c12, 1, 2)).reshape(B, m, m, m)
    x1 = -(c12 @ gc).reshape(B, 1, m, m)
    x2 = (c02 @ gc).reshape(B, m, 1, m)
    x3 = -(c01 @ gc).reshape(B, m, m, 1)
    hU = [(u @ h[:, :, None])[:, :, 0] for u in Ua]  # (B, m)
    UU = [np.einsum("bid,bid->bi", u, u) for u in Ua]
    norm2 = (
        x0**2 * np.einsum("bd,bd->b", h, h)[:, None, None, None]
        + x1**2 * UU[0][:, :, None, None]
        + x2**2 * UU[1][:, None, :, None]
        + x3**2 * UU[2][:, None, None, :]
        + 2
        * x0
        * (
            x1 * hU[0][:, :, None, None]
            + x2 * hU[1][:, None, :, None]
            + x3 * hU[2][:, None, None, :]
        )
        + 2 * x1 * x2 * (Ua[0] @ np.swapaxes(Ua[1], 1, 2))[:, :, :, None]
        + 2 * x1 * x3 * (Ua[0] @ np.swapaxes(Ua[2], 1, 2))[:, :, None, :]
        + 2 * x2 * x3 * (Ua[1] @ np.swapaxes(Ua[2], 1, 2))[:, None, :, :]
    )
    degenerate |= _fold(best, x0, x1, x2, x3, norm2, col_scale)

    # (3, 2, 1): polygon i whole, edge e of j, vertex v of k (between edges v-1 and v), the
    # six orders stacked on axis 1: columns [g, P_j[e], P_k[v-1], P_k[v]] and
    # a = b h + s_e U_j[e] + s' U_k[v-1] + s'' U_k[v].
    order = list(itertools.permutations(range(3)))
    J = [o[1] for o in order]
    K = [o[2] for o in order]
    Ps, Us = np.stack(P, axis=1), np.stack(Ua, axis=1)  # (B, 3, m, 3), (B, 3, m, 6)
    PJ, PK, UJ, UK = Ps[:, J], Ps[:, K], Us[:, J], Us[:, K]
    PKp, UKp = np.roll(PK, 1, axis=2), np.roll(UK, 1, axis=2)
    gv = g[:, None, None, :]

    def dot(u: FloatArray, v: FloatArray) -> FloatArray:
        return np.einsum("bpid,bpid->bpi", u, v)

    def outer(u: FloatArray, v: FloatArray) -> FloatArray:
        return u @ np.swapaxes(v, -1, -2)

    ck = _cross3(PKp, PK)  # (B, 6, m, 3)
    x0 = outer(PJ, ck)  # (B, 6, e, v)
    x1 = -(ck.reshape(B, 6 * m, 3) @ g[:, :, None]).reshape(B, 6, 1, m)
    x2 = outer(PJ, _cross3(PK, gv))
    x3 = -outer(PJ, _cross3(PKp, gv))
    hh = np.einsum("bd,bd->b", h, h)[:, None, None, None]
    hUJ, hUKp, hUK = (
        (u.reshape(B, 6 * m, 6) @ h[:, :, None]).reshape(B, 6, m) for u in (UJ, UKp, UK)
    )
    norm2 = (
        x0**2 * hh
        + x1**2 * dot(UJ, UJ)[..., None]
        + x2**2 * dot(UKp, UKp)[:, :, None, :]
        + x3**2 * dot(UK, UK)[:, :, None, :]
        + 2 * x0 * x1 * hUJ[..., None]
        + 2 * x0 * x2 * hUKp[:, :, None, :]
        + 2 * x0 * x3 * hUK[:, :, None, :]
        + 2 * x1 * x2 * outer(UJ, UKp)
        + 2 * x1 * x3 * outer(UJ, UK)
        + 2 * x2 * x3 * dot(UKp, UK)[:, :, None, :]
    )
    degenerate |= _fold(best, x0, x1, x2, x3, norm2, col_scale)
    # (3, 3, 0): polygons i and j whole, alpha_k free (tested at k's vertices).
    for k in range(3):
        gij = g - Ni[k][:, 2, :]  # (B, 3)
        x = _null4(gij, Ni[k][:, 0, :], Ni[k][:, 1, :], Ni[k][:, 2, :])  # (B, 4)
        alpha_k = x[:, 1:]
        a = (
            x[:, 0:1] * sum(Qi[i][:, :, 2] for i in range(3) if i != k)
            + (Qi[k] @ alpha_k[:, :, None])[:, :, 0]
        )
        side = alpha_k @ V.T - x[:, 0:1]  # (B, m): alpha_k . z - b at k's vertices
        offsets(x[:, None], a[:, None], -side[:, None], col_scale)
    out = np.where(best > MARGIN_TOLERANCE * scale, best, 0.0)
    return np.where(degenerate | ~np.isfinite(best), np.nan, out)
