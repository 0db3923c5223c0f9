"""Grasp quality: Ferrari-Canny epsilon (L1, L-infinity), volume, task wrench space, sigma_min.

The grasp wrench space (GWS) is the set of object wrenches the contacts can apply with a
bounded effort. With the sum of the normal forces at most one (L1) it is
``conv(union_i W_i)``; with each normal force at most one (L-infinity) it is the Minkowski sum
``sum_i conv({0} union W_i)``, ``W_i`` being contact ``i``'s primitive wrenches. The epsilon
metric is the radius of the largest ball about the origin inside the GWS: the magnitude of the
smallest external wrench that, applied in the worst direction, the grasp can just resist
(Ferrari and Canny 1992). Moments are divided by the torque scale ``rho`` [m] so that the ball
mixes forces and moments in commensurate units.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError

from taskspace._validation import as_float_array
from taskspace.errors import InvalidInputError, SolverError
from taskspace.grasping.closure import check_wrenches, closure_lp
from taskspace.grasping.contact import (
    GraspContact,
    check_center,
    check_contacts,
    grasp_radius,
    primitive_wrenches,
)
from taskspace.grasping.epsilon import (
    MARGIN_TOLERANCE,
    epsilon_l1_fast,
    epsilon_linf_compiled,
)
from taskspace.grasping.grasp_matrix import grasp_matrix

FloatArray = npt.NDArray[np.float64]

MAX_LINF_POINTS = 5_000
"""Largest point set of the L-infinity Minkowski sum handed to qhull (6-D hulls of more points
take minutes: the sum's vertices grow quickly with the number of contacts)."""


@dataclass(frozen=True)
class GraspQuality:
    """Quality measures of one grasp (0 for the wrench-space ones when not in closure).

    Attributes:
        epsilon_l1: Ferrari-Canny epsilon with the sum of normal forces at most 1.
        epsilon_linf: the same with each normal force at most 1.
        volume: volume of the L1 grasp wrench space.
        sigma_min: least singular value of the grasp matrix ``G``.
        torque_scale: ``rho`` [m] used to divide moments.
    """

    epsilon_l1: float
    epsilon_linf: float
    volume: float
    sigma_min: float
    torque_scale: float


def _hull(points: FloatArray) -> ConvexHull | None:
    try:
        return ConvexHull(points)
    except (QhullError, ValueError):
        return None


def _margin(hull: ConvexHull | None) -> float:
    if hull is None:
        return 0.0
    margin = float(-hull.equations[:, -1].max())
    scale = float(np.abs(hull.points).max())
    return margin if margin > MARGIN_TOLERANCE * scale else 0.0


def wrench_space_l1(W: FloatArray) -> ConvexHull | None:
    """The L1 grasp wrench space ``conv{w_k}`` (None when it is flat)."""
    return _hull(_wrenches(W))


def _wrenches(W: object) -> FloatArray:
    """Finite ``(K, d)`` wrenches with ``d >= 2`` (qhull's least dimension)."""
    normalized, scale = check_wrenches(W)
    if normalized.shape[1] < 2:
        raise InvalidInputError(
            f"W must have at least 2 columns (wrench components) for a hull, got {normalized.shape}"
        )
    return normalized * scale


def _owners(owner: object, rows: int) -> npt.NDArray[np.int64]:
    """``owner`` as an int array of one contact index per row of ``W``."""
    try:
        owners = np.asarray(owner)
    except (TypeError, ValueError):
        owners = np.zeros(0)
    if owners.shape != (rows,) or owners.dtype.kind not in "iu":
        raise InvalidInputError(
            f"owner must give the contact index (an int) of each of the {rows} rows of W, "
            f"as returned by primitive_wrenches; got {np.shape(owners)} {owners.dtype} values"
        )
    return owners.astype(np.int64)


def wrench_space_linf(W: FloatArray, owner: list[int]) -> ConvexHull | None:
    """The L-infinity grasp wrench space, a Minkowski sum of one hull per contact.

    Built contact by contact, keeping only the hull's vertices after each sum (the sum of two
    polytopes is the hull of the pairwise sums of their vertices).
    """
    W = _wrenches(W)
    d = W.shape[1]
    owners = _owners(owner, len(W))
    owner = owners.tolist()
    points = np.zeros((1, d))
    contacts = sorted(set(owner))
    for k, i in enumerate(contacts):
        generators = np.vstack([np.zeros((1, d)), W[owners == i]])
        if len(points) * len(generators) > MAX_LINF_POINTS:
            raise SolverError(
                f"the L-infinity wrench space of {len(contacts)} contacts is too large to build "
                f"exactly: {len(points) * len(generators)} candidate vertices after "
                f"{k + 1} contacts (limit MAX_LINF_POINTS = {MAX_LINF_POINTS}); use the L1 "
                "epsilon (epsilon_l1, grasp_quality(..., linf=False)), fewer contacts or "
                "fewer cone edges"
            )
        points = (points[:, None, :] + generators[None, :, :]).reshape(-1, d)
        if len(points) > d + 1:
            hull = _hull(points)
            if hull is not None:
                points = points[hull.vertices]
    return _hull(points)


def epsilon_l1(W: FloatArray) -> float:
    """Ferrari-Canny epsilon of the L1 wrench space of primitive wrenches ``W`` (rows).

    0 when the origin is not strictly inside (margins within :data:`MARGIN_TOLERANCE` of the
    largest wrench entry count as 0). Computed by :func:`epsilon_l1_fast` (one certified
    unmerged hull); :func:`wrench_space_l1` gives the hull itself.
    """
    return epsilon_l1_fast(_wrenches(W))


def epsilon_linf(W: FloatArray, owner: list[int], *, native: bool = True) -> float:
    """Ferrari-Canny epsilon of the L-infinity wrench space.

    With the compiled kernels built (``native``) and 6-D wrenches, the epsilon comes from the
    support function of the Minkowski sum (``epsilon_linf_compiled`` of
    :mod:`taskspace.grasping.epsilon`, certified; any number of contacts). Otherwise, or when
    it cannot certify, from the hull of the sum (:func:`wrench_space_linf`;
    :class:`SolverError` past :data:`MAX_LINF_POINTS` candidate vertices). Margins within
    :data:`MARGIN_TOLERANCE` of the largest entry count as 0 (of ``W`` for the kernel, of the
    sum's points for the hull).
    """
    if native:
        wrenches = _wrenches(W)
        value = epsilon_linf_compiled(wrenches, _owners(owner, len(wrenches)))
        if value is not None:
            return value
    return _margin(wrench_space_linf(W, owner))


def grasp_quality(
    contacts: list[GraspContact],
    *,
    edges: int = 8,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
    linf: bool = True,
) -> GraspQuality:
    """Every quality measure of a grasp.

    Args:
        contacts: the grasp.
        edges: edges of each linearized friction cone.
        center: moment reference point [m] (default: origin of the object frame).
        torque_scale: moment scale ``rho`` [m] (default: the grasp radius).
        linf: compute the L-infinity epsilon (:func:`epsilon_linf`: without the compiled
            kernel a Minkowski sum whose size grows quickly with the number of contacts,
            :class:`SolverError` past :data:`MAX_LINF_POINTS`); ``False`` reports it as NaN.
    """
    contacts = check_contacts(contacts)
    c = check_center(center)
    W, owner = primitive_wrenches(contacts, edges=edges, center=c, torque_scale=torque_scale)
    rho = float(torque_scale) if torque_scale is not None else grasp_radius(contacts, c)
    l1 = wrench_space_l1(W)
    G = grasp_matrix(contacts, c)
    G = G / np.array([1, 1, 1, rho, rho, rho])[:, None]
    sigma = np.linalg.svd(G, compute_uv=False)
    return GraspQuality(
        epsilon_l1=_margin(l1),
        epsilon_linf=epsilon_linf(W, owner) if linf else float("nan"),
        volume=float(l1.volume) if l1 is not None else 0.0,
        sigma_min=float(sigma[-1]) if len(sigma) == 6 else 0.0,
        torque_scale=float(rho),
    )


def task_wrench_scale(W: FloatArray, task_wrenches: FloatArray) -> float:
    """The largest ``k`` such that ``k`` times the task wrench set fits in the L1 GWS.

    Args:
        W: primitive wrenches (rows), moments already divided by the torque scale.
        task_wrenches: vertices of the required wrench set (rows, same scaling), e.g. the
            weight of the object in every orientation plus a disturbance box.

    Returns:
        ``k`` (``inf`` when every task wrench is zero; 0 when the origin is not inside the
        GWS): the grasp can apply every task wrench scaled by ``k``.
    """
    W = _wrenches(W)
    T = np.atleast_2d(as_float_array(task_wrenches, "task_wrenches"))
    if T.ndim != 2 or T.shape[1] != W.shape[1] or T.shape[0] == 0:
        raise InvalidInputError(
            f"task_wrenches must be wrenches of {W.shape[1]} components (one a row, like W), "
            f"got shape {np.shape(task_wrenches)}"
        )
    if not np.all(np.isfinite(T)):
        raise InvalidInputError("task_wrenches must be finite (no NaN or inf entries)")
    hull = wrench_space_l1(W)
    if hull is None or _margin(hull) <= 0:
        return 0.0
    a, b = hull.equations[:, :-1], hull.equations[:, -1]
    reach = T @ a.T  # (tasks, facets): a^T t
    # relative to |t| (the facet normals are unit): an absolute 1e-15 dropped the binding
    # facets of task wrenches of size ~1e-15 (k 14 % too large) and gave inf below
    size = np.hypot.reduce(T, axis=1)[:, None]
    with np.errstate(divide="ignore", over="ignore"):
        limits = np.where(reach > 1e-15 * size, -b[None, :] / reach, np.inf)
    return float(limits.min())


def minimal_closure_subset(
    contacts: list[GraspContact],
    *,
    edges: int = 8,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
) -> list[int] | None:
    """The smallest subset of contacts (indices) that is still in force closure.

    Mishra, Schwartz and Sharir bound the number of contacts closure needs (at most 12
    frictionless, fewer with friction); the subsets are enumerated by increasing size, so the
    answer is a smallest one. None when the full grasp is not in closure.
    """
    contacts = check_contacts(contacts)
    if len(contacts) > 16:
        raise InvalidInputError(
            f"at most 16 contacts can be pruned by enumeration, got {len(contacts)}"
        )
    W, owner = primitive_wrenches(contacts, edges=edges, center=center, torque_scale=torque_scale)
    owners = np.asarray(owner)
    for size in range(1, len(contacts) + 1):
        for subset in itertools.combinations(range(len(contacts)), size):
            if closure_lp(W[np.isin(owners, subset)]).closure:
                return list(subset)
    return None
