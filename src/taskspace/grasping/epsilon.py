"""Ferrari-Canny epsilon (L1): one certified unmerged convex hull per grasp, and batches.

The L1 grasp wrench space is ``P = conv{w_k}`` and its epsilon is the distance from the origin
to the nearest facet plane: ``eps = min_j b_j`` over the facets ``a_j^T w <= b_j``
(``|a_j| = 1``), 0 when the origin is not strictly inside. Primitive wrenches are degenerate
by construction (the ``m`` edges of one friction cone are coplanar), and qhull's default
handling of that, merging facets ("Qx"), costs three times the hull itself. Here the hull is
built without merging (qhull "Q0") and its output is certified instead:

1. every facet plane has every input point on its inner side (to ``1e-12`` of the largest
   entry): then each ``b_j >= eps``, because the ball of radius ``eps`` lies inside ``P``;
2. the facets form a closed surface (every facet has all its neighbours): with 1., it is the
   boundary of ``P``, so the ray from the origin to the nearest boundary point crosses one of
   them, whose plane then has ``b_j <= eps``.

So ``min_j b_j = eps``. When either check fails, or qhull reports a precision error, the hull
is rebuilt with qhull's merging options (the exact default). A grasp out of closure is often
recognized before any hull: a direction ``c`` with ``c^T w_k >= 0`` for every ``k`` (the
mean wrench, the coordinate axes) proves it (Gordan's alternative).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError

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
    E = hull.equations
    if np.any(hull.neighbors < 0):
        return None
    violation = float((W @ E[:, :-1].T + E[:, -1]).max())
    if not violation <= CERTIFICATE_TOLERANCE:
        return None
    return -E[:, -1]


def _merged_offsets(W: FloatArray) -> FloatArray | None:
    try:
        return -ConvexHull(W).equations[:, -1]
    except (QhullError, ValueError):
        return None  # flat: the origin is not strictly inside


def _epsilon_normalized(W: FloatArray) -> float:
    """Epsilon of ``W`` scaled to a largest entry of 1 (no validation)."""
    k, d = W.shape
    if k <= d or _separated(W):
        return 0.0
    offsets = _certified_offsets(W)
    if offsets is None:
        offsets = _merged_offsets(W)
        if offsets is None:
            return 0.0
    margin = float(offsets.min())
    return margin if margin > MARGIN_TOLERANCE else 0.0


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


def epsilon_l1_fast(W: FloatArray) -> float:
    """Ferrari-Canny epsilon of the L1 wrench space of primitive wrenches ``W`` (rows).

    ``eps = min_j b_j`` over the facets ``a_j^T w <= b_j`` of ``conv W``; 0 when the origin
    is not strictly inside (margins within :data:`MARGIN_TOLERANCE` of the largest entry
    count as 0).

    Args:
        W: primitive wrenches, shape ``(K, d)`` with ``d >= 2`` (finite).

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
    scale = float(np.abs(arr).max())
    return _epsilon_normalized(arr / scale) * scale if scale > 0 else 0.0


def epsilon_l1_batch(W: FloatArray) -> FloatArray:
    """Epsilon (L1) of many grasps with the same number of wrenches.

    Args:
        W: ``(B, K, d)``: grasp ``b``'s primitive wrenches are ``W[b]`` (rows).

    Returns:
        ``(B,)`` epsilons, each equal to :func:`epsilon_l1_fast` of ``W[b]``.
    """
    arr = _check_batch(W, "W")
    scale = np.abs(arr).max(axis=(1, 2))
    out = np.zeros(len(arr))
    for b in np.flatnonzero(scale > 0):
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
        rho = np.linalg.norm(r, axis=-1).max(axis=1)
        rho = np.where(rho > 1e-12, rho, 1.0)
    elif isinstance(torque_scale, (bool, np.bool_)):
        raise InvalidInputError(f"torque_scale must be a length [m] > 0, got {torque_scale!r}")
    else:
        rho = np.full(len(p), check_positive(torque_scale, "torque_scale [m]"))
    t1, t2 = _contact_frames(n)
    theta = 2.0 * np.pi * np.arange(edges) / edges
    # forces (B, k, m, 3): n + mu (cos t1 + sin t2)
    forces = n[:, :, None, :] + mu * (
        np.cos(theta)[None, None, :, None] * t1[:, :, None, :]
        + np.sin(theta)[None, None, :, None] * t2[:, :, None, :]
    )
    moments = np.cross(r[:, :, None, :], forces)
    if torsion > 0:
        both = np.stack([n, n], axis=2)
        twist = np.array([torsion, -torsion])[None, None, :, None] * n[:, :, None, :]
        forces = np.concatenate([forces, both], axis=2)
        moments = np.concatenate([moments, np.cross(r[:, :, None, :], both) + twist], axis=2)
    W = np.concatenate([forces, moments / rho[:, None, None, None]], axis=3)
    return W.reshape(len(p), -1, 6)


def grasp_epsilon_batch(
    positions: FloatArray,
    normals: FloatArray,
    *,
    mu: float = 0.5,
    edges: int = 8,
    torsion: float = 0.0,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
) -> FloatArray:
    """Epsilon (L1) of ``B`` grasps of ``k`` friction contacts, ``(B,)`` (0 out of closure).

    The arguments are those of :func:`primitive_wrenches_batch`.
    """
    return epsilon_l1_batch(
        primitive_wrenches_batch(
            positions,
            normals,
            mu=mu,
            edges=edges,
            torsion=torsion,
            center=center,
            torque_scale=torque_scale,
        )
    )
