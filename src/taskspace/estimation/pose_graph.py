"""Graph-based SLAM on SE(2): pose graphs with odometry, landmark and loop-closure factors.

Unknowns are robot poses ``x_i = (t_i, theta_i)`` [m, rad] and 2-D landmarks ``l_k`` [m].
Every factor is a Gaussian constraint ``exp(-1/2 e^T Omega e)``:

* pose-pose (odometry and loop closure), measurement ``Z = (t_z, theta_z)`` of ``X_i^-1 X_j``:
  ``e = ( R_z^T (R_i^T (t_j - t_i) - t_z),  wrap(theta_j - theta_i - theta_z) )``;
* pose-landmark, measurement ``z`` of the landmark in the robot frame:
  ``e = R_i^T (l_k - t_i) - z``.

The MAP estimate minimizes ``sum e^T Omega e``; Gauss-Newton / Levenberg-Marquardt solve
``(J^T J + lambda D) dx = -J^T e`` with a sparse ``J`` (scipy.sparse, SuperLU), pose 0 fixed
to remove the gauge freedom. Jacobians (Grisetti et al., "A tutorial on graph-based SLAM"):
``de/dx_i = [[-R_z^T R_i^T, R_z^T dR_i^T/dtheta (t_j - t_i)], [0, 0, -1]]``,
``de/dx_j = [[R_z^T R_i^T, 0], [0, 0, 1]]``.

Thread safety: :class:`PoseGraph` is plain data (see there); :class:`PoseGraphOptions` is
immutable; :func:`optimize_pose_graph` keeps its state local to the call.
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from taskspace._validation import FloatArray, as_float_array, check_count
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation.motion_models import wrap_angle

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class PoseEdge:
    """Relative-pose factor between poses ``i`` and ``j`` (odometry or loop closure).

    Attributes:
        i: index of the first pose.
        j: index of the second pose.
        measurement: ``(3,)`` measured ``X_i^-1 X_j`` as ``(dx, dy, dtheta)`` [m, m, rad].
        information: ``(3, 3)`` information matrix ``Omega`` (inverse covariance).
    """

    i: int
    j: int
    measurement: FloatArray
    information: FloatArray


@dataclass(frozen=True)
class LandmarkEdge:
    """Landmark observation factor: landmark ``k`` seen from pose ``i``.

    Attributes:
        i: pose index.
        k: landmark index.
        measurement: ``(2,)`` landmark position in the robot frame [m].
        information: ``(2, 2)`` information matrix.
    """

    i: int
    k: int
    measurement: FloatArray
    information: FloatArray


@dataclass
class PoseGraph:
    """A pose graph: initial guesses and factors.

    Attributes:
        poses: ``(P, 3)`` initial pose estimates.
        landmarks: ``(L, 2)`` initial landmark estimates.
        edges: pose-pose factors.
        landmark_edges: pose-landmark factors.
        fixed: index of the pose held fixed (gauge).

    Thread safety: a graph is plain data, not locked. :func:`optimize_pose_graph` only reads
    it (its workspace is per call), so several threads may optimize one graph at once; do not
    mutate a graph (append edges, replace poses) while another thread optimizes it.
    """

    poses: FloatArray
    landmarks: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    edges: list[PoseEdge] = field(default_factory=list)
    landmark_edges: list[LandmarkEdge] = field(default_factory=list)
    fixed: int = 0

    def validate(self) -> None:
        """Check shapes, types, indices and information matrices; raise taskspace errors.

        Node indices must be integers (``1.5`` was truncated to 1); measurements finite real
        vectors (NaN gave a FAILED result, complex values were truncated); information
        matrices finite and symmetric (positive definiteness is checked by the optimizer).
        Nodes not connected to the fixed pose are reported by :meth:`disconnected`.
        """
        P = as_float_array(self.poses, "poses")
        if P.ndim != 2 or P.shape[1] != 3:
            raise ShapeError("poses", (-1, 3), tuple(P.shape))
        L = as_float_array(self.landmarks, "landmarks")
        if L.ndim != 2 or L.shape[1] != 2:
            raise ShapeError("landmarks", (-1, 2), tuple(L.shape))
        if not (np.isfinite(P).all() and np.isfinite(L).all()):
            raise InvalidInputError("pose graph has non-finite initial poses or landmarks")
        n = P.shape[0]
        if n == 0:
            raise InvalidInputError("the pose graph has no pose")
        fixed = _index(self.fixed, "fixed")
        if not 0 <= fixed < n:
            raise InvalidInputError(f"fixed pose {self.fixed} is not in [0, {n})")
        for name, edges, kind in (
            ("edges", self.edges, PoseEdge),
            ("landmark_edges", self.landmark_edges, LandmarkEdge),
        ):
            if not isinstance(edges, (list, tuple)) or not all(isinstance(e, kind) for e in edges):
                raise InvalidInputError(
                    f"{name} must be a list of {kind.__name__}, got {type(edges).__name__}"
                    + (
                        f" holding {sorted({type(e).__name__ for e in edges})}"
                        if isinstance(edges, (list, tuple))
                        else ""
                    )
                )
        if _edges_ok(self.edges, ("i", "j"), n, n, 3) and _edges_ok(
            self.landmark_edges, ("i", "k"), n, L.shape[0], 2
        ):
            return  # the vectorized checks passed (M3500: ~1 ms instead of ~300 ms per edge)
        # something is wrong: find the first bad edge, edge by edge, for the message
        for e in self.edges:
            what = f"edge ({e.i!r}, {e.j!r})"
            i, j = _index(e.i, f"{what} index i"), _index(e.j, f"{what} index j")
            if not (0 <= i < n and 0 <= j < n) or i == j:
                raise InvalidInputError(f"{what} refers to missing poses (have {n})")
            _vector(e.measurement, 3, f"measurement of {what}")
            _information(e.information, 3, f"information of {what}")
        for le in self.landmark_edges:
            what = f"landmark edge ({le.i!r}, {le.k!r})"
            i, k = _index(le.i, f"{what} pose index"), _index(le.k, f"{what} landmark index")
            if not (0 <= i < n and 0 <= k < L.shape[0]):
                raise InvalidInputError(f"{what} refers to missing nodes")
            _vector(le.measurement, 2, f"measurement of {what}")
            _information(le.information, 2, f"information of {what}")

    def disconnected(self) -> tuple[list[int], list[int]]:
        """Poses and landmarks joined to the fixed pose by no chain of factors.

        Any placement of them is optimal (gauge freedom): the optimizer leaves them at their
        initial guess and says so in ``PoseGraphResult.message``.
        """
        from scipy.sparse.csgraph import connected_components

        n, num_landmarks = len(self.poses), len(self.landmarks)
        a = [int(e.i) for e in self.edges] + [int(e.i) for e in self.landmark_edges]
        b = [int(e.j) for e in self.edges] + [n + int(e.k) for e in self.landmark_edges]
        size = n + num_landmarks
        adj = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(size, size))
        _, labels = connected_components(adj, directed=False)
        loose = np.flatnonzero(labels != labels[int(self.fixed)])
        return loose[loose < n].tolist(), (loose[loose >= n] - n).tolist()


def _edges_ok(edges: Sequence[Any], names: tuple[str, str], n_a: int, n_b: int, size: int) -> bool:
    """All edges valid, checked on stacked arrays (``False``: check them one by one)."""
    if not edges:
        return True
    a = [getattr(e, names[0]) for e in edges]
    b = [getattr(e, names[1]) for e in edges]
    for idx in (a, b):  # Python or NumPy integers, not bools (checked per type: cheap)
        if not all(type(v) is int or isinstance(v, np.integer) for v in idx):
            return False
    ia, ib = np.asarray(a), np.asarray(b)
    if ia.min() < 0 or ia.max() >= n_a or ib.min() < 0 or ib.max() >= n_b:
        return False
    if names[1] == "j" and np.any(ia == ib):
        return False
    try:
        Z = np.asarray([e.measurement for e in edges])
        W = np.asarray([e.information for e in edges])
    except (TypeError, ValueError):
        return False
    if Z.dtype.kind not in "iuf" or W.dtype.kind not in "iuf":
        return False
    if Z.shape != (len(edges), size) or W.shape != (len(edges), size, size):
        return False
    if not (np.isfinite(Z).all() and np.isfinite(W).all()):
        return False
    scale = np.maximum(1.0, np.abs(W).max(axis=(1, 2)))
    asym = np.abs(W - W.transpose(0, 2, 1)).max(axis=(1, 2))
    return bool(np.all(asym <= 1e-9 * scale))


def _index(value: Any, name: str) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InvalidInputError(f"{name} must be an integer, got {value!r}")
    return int(value)


def _vector(value: Any, size: int, name: str) -> FloatArray:
    arr = as_float_array(value, name)
    if arr.shape != (size,):
        raise ShapeError(name, (size,), tuple(arr.shape))
    if not np.isfinite(arr).all():
        raise InvalidInputError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def _information(value: Any, size: int, name: str) -> FloatArray:
    arr = as_float_array(value, name)
    if arr.shape != (size, size):
        raise ShapeError(name, (size, size), tuple(arr.shape))
    if not np.isfinite(arr).all():
        raise InvalidInputError(f"{name} must be finite")
    scale = max(1.0, float(np.max(np.abs(arr))))
    if np.max(np.abs(arr - arr.T)) > 1e-9 * scale:
        raise InvalidInputError(f"{name} must be symmetric, got {arr.tolist()}")
    return arr


MAX_GENERATED_POSES = 10_000_000
"""Largest ``num_poses`` of :func:`manhattan_pose_graph`."""


class PoseGraphStatus(enum.Enum):
    """Outcome of a pose-graph optimization."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    FAILED = "failed"


@dataclass(frozen=True, kw_only=True)
class PoseGraphOptions:
    """Settings of :func:`optimize_pose_graph`.

    Attributes:
        method: ``"gauss_newton"`` or ``"levenberg_marquardt"``.
        max_iterations: limit on the linear solves (an integer >= 1; rejected damped steps
            count).
        tolerance: stop when the relative cost decrease or the step norm is below this.
        initial_lambda: initial LM damping (relative to the mean diagonal of ``J^T J``;
            absolute when that mean is 0).
    """

    method: str = "levenberg_marquardt"
    max_iterations: int = 50
    tolerance: float = 1e-9
    initial_lambda: float = 1e-8


@dataclass(frozen=True)
class PoseGraphResult:
    """Optimized pose graph.

    Attributes:
        success: ``True`` when converged.
        status: outcome.
        poses: ``(P, 3)`` optimized poses.
        landmarks: ``(L, 2)`` optimized landmarks.
        iterations: number of linear solves.
        initial_cost: ``sum e^T Omega e`` at the initial guess (chi-square).
        final_cost: at the solution.
        cost_history: cost after each accepted iteration.
        time_s: wall time [s].
        message: diagnostic text.
    """

    success: bool
    status: PoseGraphStatus
    poses: FloatArray
    landmarks: FloatArray
    iterations: int
    initial_cost: float
    final_cost: float
    cost_history: list[float]
    time_s: float
    message: str = ""


def _rot(th: FloatArray) -> FloatArray:
    c, s = np.cos(th), np.sin(th)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _poses(x: Any, name: str) -> FloatArray:
    """Real finite poses ``(..., 3)`` (a wrong last size was a bare IndexError)."""
    arr = as_float_array(x, name)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ShapeError(name, (-1, 3) if arr.ndim > 1 else (3,), tuple(arr.shape))
    if not np.isfinite(arr).all():
        raise InvalidInputError(f"{name} must hold finite poses (x, y, theta)")
    return arr


def compose(a: Any, b: Any) -> FloatArray:
    """SE(2) composition ``a (+) b`` of poses ``(..., 3)``."""
    A, B = _poses(a, "a"), _poses(b, "b")
    c, s = np.cos(A[..., 2]), np.sin(A[..., 2])
    return np.stack(
        [
            A[..., 0] + c * B[..., 0] - s * B[..., 1],
            A[..., 1] + s * B[..., 0] + c * B[..., 1],
            wrap_angle(A[..., 2] + B[..., 2]),
        ],
        axis=-1,
    )


def relative(a: Any, b: Any) -> FloatArray:
    """SE(2) relative pose ``a^-1 b`` of poses ``(..., 3)``."""
    A, B = _poses(a, "a"), _poses(b, "b")
    c, s = np.cos(A[..., 2]), np.sin(A[..., 2])
    dx, dy = B[..., 0] - A[..., 0], B[..., 1] - A[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(B[..., 2] - A[..., 2])], -1)


class _Problem:
    """Vectorized residuals and sparse Jacobian of a pose graph."""

    def __init__(self, g: PoseGraph) -> None:
        self.P = len(g.poses)
        self.L = len(g.landmarks)
        E = len(g.edges)
        self.ei = np.array([e.i for e in g.edges], dtype=np.intp)
        self.ej = np.array([e.j for e in g.edges], dtype=np.intp)
        self.Z = np.array([e.measurement for e in g.edges], dtype=np.float64).reshape(E, 3)
        info = np.array([e.information for e in g.edges], dtype=np.float64).reshape(E, 3, 3)
        K = len(g.landmark_edges)
        linfo = np.array([e.information for e in g.landmark_edges], dtype=np.float64).reshape(
            K, 2, 2
        )
        # Every information matrix divided by the same power of two (exact; the MAP does not
        # change): information near 1e300 overflowed J^T J, every step was rejected and the
        # initial guess came back "converged". Costs are reported in the user's units.
        top = max(
            float(np.max(np.abs(info), initial=0.0)), float(np.max(np.abs(linfo), initial=0.0))
        )
        self.exponent = int(np.frexp(top)[1]) if top > 0 else 0
        info, linfo = np.ldexp(info, -self.exponent), np.ldexp(linfo, -self.exponent)
        try:
            self.W = np.linalg.cholesky(info).transpose(0, 2, 1)  # Omega = W^T W
        except np.linalg.LinAlgError as exc:
            raise InvalidInputError(
                f"an edge information matrix is not positive definite: {exc}"
            ) from exc
        self.li = np.array([e.i for e in g.landmark_edges], dtype=np.intp)
        self.lk = np.array([e.k for e in g.landmark_edges], dtype=np.intp)
        self.lz = np.array([e.measurement for e in g.landmark_edges], dtype=np.float64).reshape(
            K, 2
        )
        try:
            self.lW = np.linalg.cholesky(linfo).transpose(0, 2, 1)
        except np.linalg.LinAlgError as exc:
            raise InvalidInputError(
                f"a landmark information matrix is not positive definite: {exc}"
            ) from exc
        self.fixed = g.fixed
        # Column index of each variable (pose `fixed` removed).
        col = np.full(3 * self.P + 2 * self.L, -1, dtype=np.intp)
        free = np.ones(3 * self.P + 2 * self.L, dtype=bool)
        free[3 * g.fixed : 3 * g.fixed + 3] = False
        col[free] = np.arange(int(free.sum()))
        self.col = col
        self.nvar = int(free.sum())
        # Sparsity pattern (rows, cols) of J, constant over iterations.
        r = np.arange(3 * E).reshape(E, 3)
        pi = 3 * self.ei[:, None] + np.arange(3)
        pj = 3 * self.ej[:, None] + np.arange(3)
        rows_p = np.repeat(r, 6, axis=1).reshape(E, 3, 6)
        cols_p = np.broadcast_to(np.concatenate([pi, pj], 1)[:, None, :], (E, 3, 6))
        rl = 3 * E + np.arange(2 * K).reshape(K, 2)
        li = 3 * self.li[:, None] + np.arange(3)
        lk = 3 * self.P + 2 * self.lk[:, None] + np.arange(2)
        rows_l = np.repeat(rl, 5, axis=1).reshape(K, 2, 5)
        cols_l = np.broadcast_to(np.concatenate([li, lk], 1)[:, None, :], (K, 2, 5))
        rows = np.concatenate([rows_p.ravel(), rows_l.ravel()])
        cols = self.col[np.concatenate([cols_p.ravel(), cols_l.ravel()])]
        self.keep = cols >= 0
        self.rows = rows[self.keep]
        self.cols = cols[self.keep]
        self.nres = 3 * E + 2 * K

    def residual(self, X: FloatArray, Lm: FloatArray) -> FloatArray:
        """Whitened residual vector ``W e``."""
        xi, xj = X[self.ei], X[self.ej]
        e = relative(self.Z, relative(xi, xj)) if len(self.ei) else np.zeros((0, 3))
        out = [np.einsum("eab,eb->ea", self.W, e).ravel()]
        if len(self.li):
            x = X[self.li]
            Rt = _rot(x[:, 2]).transpose(0, 2, 1)
            el = np.einsum("eab,eb->ea", Rt, Lm[self.lk] - x[:, :2]) - self.lz
            out.append(np.einsum("eab,eb->ea", self.lW, el).ravel())
        return np.concatenate(out)

    def jacobian(self, X: FloatArray, Lm: FloatArray) -> sp.csr_array:
        """Sparse whitened Jacobian ``W de/dx`` (pose ``fixed`` removed)."""
        E = len(self.ei)
        xi, xj = X[self.ei], X[self.ej]
        Ri_t = _rot(xi[:, 2]).transpose(0, 2, 1)
        Rz_t = _rot(self.Z[:, 2]).transpose(0, 2, 1)
        c, s = np.cos(xi[:, 2]), np.sin(xi[:, 2])
        dRi_t = np.stack([np.stack([-s, c], -1), np.stack([-c, -s], -1)], -2)
        dt = xj[:, :2] - xi[:, :2]
        A = np.zeros((E, 3, 6))
        RzRi = Rz_t @ Ri_t
        A[:, :2, :2] = -RzRi
        A[:, :2, 2] = np.einsum("eab,eb->ea", Rz_t @ dRi_t, dt)
        A[:, 2, 2] = -1.0
        A[:, :2, 3:5] = RzRi
        A[:, 2, 5] = 1.0
        vals = [np.einsum("eab,ebc->eac", self.W, A).ravel()]
        K = len(self.li)
        if K:
            x = X[self.li]
            c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
            Rt = _rot(x[:, 2]).transpose(0, 2, 1)
            dRt = np.stack([np.stack([-s, c], -1), np.stack([-c, -s], -1)], -2)
            B = np.zeros((K, 2, 5))
            B[:, :, :2] = -Rt
            B[:, :, 2] = np.einsum("eab,eb->ea", dRt, Lm[self.lk] - x[:, :2])
            B[:, :, 3:] = Rt
            vals.append(np.einsum("eab,ebc->eac", self.lW, B).ravel())
        v = np.concatenate(vals)[self.keep]
        return sp.csr_array((v, (self.rows, self.cols)), shape=(self.nres, self.nvar))

    def retract(
        self, X: FloatArray, Lm: FloatArray, dx: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        full = np.zeros(3 * self.P + 2 * self.L)
        full[self.col >= 0] = dx
        Xn = X + full[: 3 * self.P].reshape(-1, 3)
        Xn[:, 2] = wrap_angle(Xn[:, 2])
        return Xn, Lm + full[3 * self.P :].reshape(-1, 2)


def optimize_pose_graph(
    graph: PoseGraph, options: PoseGraphOptions | None = None
) -> PoseGraphResult:
    """Maximum-a-posteriori poses and landmarks of a pose graph (module docstring).

    Args:
        graph: the pose graph (initial guesses and factors).
        options: solver settings.

    Returns:
        The :class:`PoseGraphResult`.

    Raises:
        InvalidInputError: malformed graph (also: several poses and no edge nor landmark
            observation, so that nothing determines them), bad options or unknown method.
    """
    o = options or PoseGraphOptions()
    if o.method not in ("gauss_newton", "levenberg_marquardt"):
        from taskspace.errors import UnknownNameError

        raise UnknownNameError("method", o.method, ["gauss_newton", "levenberg_marquardt"])
    max_iterations = check_count(o.max_iterations, "max_iterations", minimum=1)
    for name in ("tolerance", "initial_lambda"):
        value = getattr(o, name)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
            raise InvalidInputError(f"{name} must be a number >= 0, got {value!r}")
        if not (np.isfinite(value) and value >= 0.0):
            raise InvalidInputError(f"{name} must be finite and >= 0, got {value!r}")
    graph.validate()
    if len(graph.poses) > 1 and not graph.edges and not graph.landmark_edges:
        raise InvalidInputError(
            f"the pose graph has {len(graph.poses)} poses but no edge and no landmark "
            "observation: nothing determines the poses other than the fixed one; add "
            "PoseEdge or LandmarkEdge factors"
        )
    loose_poses, loose_landmarks = graph.disconnected()
    t0 = time.perf_counter()
    prob = _Problem(graph)
    X = np.array(graph.poses, dtype=np.float64)
    Lm = np.array(graph.landmarks, dtype=np.float64).reshape(-1, 2)
    r = prob.residual(X, Lm)
    cost = float(r @ r)
    if not np.isfinite(cost):
        raise InvalidInputError(
            "the initial cost sum e^T Omega e overflows float64: the initial guess is too far "
            "from the measurements for the given information matrices (or the values are "
            "beyond ~1e150); rescale the units"
        )
    initial = cost
    history = [cost]
    lam = None
    status = PoseGraphStatus.MAX_ITERATIONS
    message = ""
    it = 0
    while it < max_iterations:
        J = prob.jacobian(X, Lm)
        Jt = J.T.tocsr()
        H = (Jt @ J).tocsc()
        g = Jt @ r
        diag = H.diagonal()
        if lam is None:
            scale = float(np.mean(diag)) if diag.size else 0.0
            scale = scale if np.isfinite(scale) and scale > 0.0 else 1.0
            lam = o.initial_lambda * scale if o.method != "gauss_newton" else 0.0
        accepted = False
        while True:
            it += 1
            Hd = H + sp.diags(lam * np.maximum(diag, 1e-12), format="csc") if lam > 0 else H
            try:
                # SPD normal equations: symmetric minimum-degree ordering, no pivoting.
                lu = spla.splu(
                    Hd,
                    permc_spec="MMD_AT_PLUS_A",
                    diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True},
                )
                dx = lu.solve(-g)
            except RuntimeError as exc:  # exactly singular factor
                dx = np.full(g.shape, np.nan)
                logger.debug("pose-graph factorization failed: %s", exc)
            if not np.all(np.isfinite(dx)):
                if o.method == "gauss_newton" or lam > 1e12 or it >= max_iterations:
                    status, message = PoseGraphStatus.FAILED, "singular normal equations"
                    break
                lam = 10.0 * lam if lam > 0.0 else 1e-12  # damping 0 would stay 0
                continue
            Xn, Ln = prob.retract(X, Lm, dx)
            rn = prob.residual(Xn, Ln)
            cn = float(rn @ rn)
            if cn <= cost or o.method == "gauss_newton":
                accepted = True
                break
            lam = 10.0 * lam if lam > 0.0 else 1e-12
            if lam > 1e12 or it >= max_iterations:
                break
        if status is PoseGraphStatus.FAILED:
            break
        if not accepted:
            status, message = PoseGraphStatus.CONVERGED, "no further decrease"
            break
        step = float(np.linalg.norm(dx))
        rel = (cost - cn) / max(cost, 1e-300)
        X, Lm, r, cost = Xn, Ln, rn, cn
        history.append(cost)
        if lam:
            lam = max(lam / 10.0, 1e-15)
        if abs(rel) < o.tolerance or step < o.tolerance:
            status = PoseGraphStatus.CONVERGED
            break
    ok = status is PoseGraphStatus.CONVERGED
    if loose_poses or loose_landmarks:
        message = (message + "; " if message else "") + (
            f"poses {loose_poses[:20]} and landmarks {loose_landmarks[:20]} are not connected "
            "to the fixed pose by any factor: undetermined, left at their initial guess"
        )
    if not ok:
        logger.info("pose graph optimization stopped: %s %s", status.value, message)
    return PoseGraphResult(
        success=ok,
        status=status,
        poses=X,
        landmarks=Lm,
        iterations=it,
        initial_cost=float(np.ldexp(initial, prob.exponent)),
        final_cost=float(np.ldexp(cost, prob.exponent)),
        cost_history=[float(np.ldexp(c, prob.exponent)) for c in history],
        time_s=time.perf_counter() - t0,
        message=message,
    )


def manhattan_pose_graph(
    num_poses: int,
    rng: np.random.Generator,
    *,
    sigma_xy: float = 0.05,
    sigma_theta: float = 0.01,
    grid_size: int = 20,
    max_closures_per_pose: int = 1,
    noise_scale: float = 1.0,
) -> tuple[PoseGraph, FloatArray]:
    """Manhattan-world pose graph in the style of the M3500 data set.

    The robot walks on a ``grid_size x grid_size`` grid of 1 m cells, going straight or turning
    by +-90 degrees; odometry edges link consecutive poses, and a loop closure links the
    current pose to an earlier pose at the same grid cell. Edge measurements get Gaussian noise
    ``N(0, diag(sigma_xy^2, sigma_xy^2, sigma_theta^2))`` and that covariance's inverse as
    information; the initial guess composes the noisy odometry. ``noise_scale = 0`` gives
    noise-free measurements (with the same information matrices).

    Returns:
        The graph and the ``(num_poses, 3)`` ground-truth poses.
    """
    num_poses = check_count(num_poses, "num_poses", minimum=2)
    if num_poses > MAX_GENERATED_POSES:
        raise InvalidInputError(
            f"num_poses = {num_poses:,} exceeds {MAX_GENERATED_POSES:,} (each pose and edge is "
            "a Python object of ~1 kB)"
        )
    grid_size = check_count(grid_size, "grid_size", minimum=2)
    max_closures_per_pose = check_count(max_closures_per_pose, "max_closures_per_pose")
    for name, value in (("sigma_xy", sigma_xy), ("sigma_theta", sigma_theta)):
        if not (isinstance(value, (int, float, np.number)) and not isinstance(value, bool)):
            raise InvalidInputError(f"{name} must be a number > 0, got {value!r}")
        if not (np.isfinite(value) and value > 0):
            raise InvalidInputError(f"{name} must be finite and > 0 (use noise_scale=0)")
    if not (
        isinstance(noise_scale, (int, float, np.number))
        and not isinstance(noise_scale, bool)
        and np.isfinite(noise_scale)
        and noise_scale >= 0
    ):
        raise InvalidInputError(f"noise_scale must be finite and >= 0, got {noise_scale!r}")
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(
            f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}"
        )
    truth = np.zeros((num_poses, 3))
    cell = np.array([grid_size // 2, grid_size // 2])
    heading = 0
    truth[0, :2] = cell
    dirs = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]])
    visits: dict[tuple[int, int], list[int]] = {(int(cell[0]), int(cell[1])): [0]}
    closures: list[tuple[int, int]] = []
    for k in range(1, num_poses):
        u = rng.random()
        turn = 0 if u < 0.7 else (1 if u < 0.85 else -1)
        h = (heading + turn) % 4
        for _ in range(4):
            nxt = cell + dirs[h]
            if 0 <= nxt[0] < grid_size and 0 <= nxt[1] < grid_size:
                break
            h = (h + 1) % 4
        heading = h
        cell = cell + dirs[h]
        truth[k] = [cell[0], cell[1], wrap_angle(h * np.pi / 2)]
        key = (int(cell[0]), int(cell[1]))
        prev = [j for j in visits.get(key, []) if k - j > 5]
        if prev:
            for j in rng.choice(prev, size=min(max_closures_per_pose, len(prev)), replace=False):
                closures.append((int(j), k))
        visits.setdefault(key, []).append(k)
    if not (sigma_xy > 0 and sigma_theta > 0):
        raise InvalidInputError("sigma_xy and sigma_theta must be > 0 (use noise_scale=0)")
    cov = np.array([sigma_xy, sigma_xy, sigma_theta]) ** 2
    info = np.diag(1.0 / cov)
    pairs = [(k - 1, k) for k in range(1, num_poses)] + closures
    ii = np.array([p[0] for p in pairs])
    jj = np.array([p[1] for p in pairs])
    meas = relative(truth[ii], truth[jj]) + noise_scale * rng.standard_normal(
        (len(pairs), 3)
    ) * np.sqrt(cov)
    meas[:, 2] = wrap_angle(meas[:, 2])
    edges = [PoseEdge(int(i), int(j), m, info) for i, j, m in zip(ii, jj, meas)]
    init = np.zeros((num_poses, 3))
    init[0] = truth[0]
    for k in range(1, num_poses):
        init[k] = compose(init[k - 1], meas[k - 1])
    return PoseGraph(poses=init, edges=edges), truth
