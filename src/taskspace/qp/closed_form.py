"""Closed-form inverse kinematics of the lecture notes: the reference implementations.

* weighted pseudo-inverse ``J# = (J^T C J + W)^-1 J^T C`` and its Woodbury form
  ``W^-1 J^T (J W^-1 J^T + C^-1)^-1`` (slide 2:26);
* singularity-robust (damped) pseudo-inverse (slide 2:58);
* nullspace projector ``I - J# J`` and the one-step solution with nullspace motion
  ``q* = q' + J# (y* - y') + (I - J# J) h`` (slide 2:29);
* the multi-task stacked step ``q* = q0 - (J^T J + W)^-1 J^T Phi(q0)`` (slides 2:40-2:41);
* the hierarchical nullspace formula of slide 2:43 for any number of levels, and the exact
  limit ``rho_1 >> rho_2 >> ...`` (recursive nullspace projection).

These are dense, direct and meant for checking the QP solvers, teaching and small problems.
Every input is checked (shapes, finite values, metrics symmetric positive (semi-)definite); a
singular system is an :class:`~taskspace.errors.InvalidInputError` saying which matrix.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_matrix, as_vector, check_positive
from taskspace.errors import InvalidInputError

_SYMMETRY_TOLERANCE = 1e-9
"""Relative asymmetry accepted in a metric (of its largest entry)."""


def _jacobian(J: Any, name: str = "J", columns: int | None = None) -> FloatArray:
    """``J`` as a finite (d, n) matrix."""
    return as_matrix(J, (None, columns), name)


def _metric(M: Any, n: int, name: str, *, definite: bool) -> FloatArray:
    """``M`` as a finite symmetric (n, n) matrix, positive definite (or semi-definite)."""
    arr = as_matrix(M, (n, n), name)
    if n == 0:
        return arr
    scale = float(np.abs(arr).max())
    if float(np.abs(arr - arr.T).max()) > _SYMMETRY_TOLERANCE * scale:
        raise InvalidInputError(
            f"{name} must be symmetric, got |{name} - {name}^T| up to "
            f"{float(np.abs(arr - arr.T).max()):.3g}"
        )
    least = float(np.linalg.eigvalsh(0.5 * (arr + arr.T))[0])
    if least <= 0.0 if definite else least < -_SYMMETRY_TOLERANCE * max(scale, 1e-300):
        kind = "definite" if definite else "semi-definite"
        raise InvalidInputError(
            f"{name} must be positive {kind} (a metric), but its smallest eigenvalue is {least:.6g}"
        )
    return arr


def _solve(M: FloatArray, B: FloatArray, what: str) -> FloatArray:
    """``M^-1 B``, or an InvalidInputError naming ``what`` when ``M`` is singular."""
    _finite(M, what)
    try:
        return _finite(np.asarray(np.linalg.solve(M, B)), f"the solution with {what}")
    except np.linalg.LinAlgError:
        raise InvalidInputError(
            f"{what} is singular: make the metric positive definite (or add damping)"
        ) from None


def _finite(arr: FloatArray, what: str) -> FloatArray:
    """``arr``, or an InvalidInputError when it overflowed (finite inputs, inf or NaN results).

    Inputs are finite when this runs: a non-finite product means entries whose squares
    exceed double precision (``|J| > ~1e154``), where every formula here returns NaN.
    """
    if not np.isfinite(arr).all():
        raise InvalidInputError(
            f"{what} is not finite: the inputs' products overflow double precision (entries "
            "beyond ~1e154 multiply to inf); scale the Jacobians, metrics and errors"
        )
    return arr


def weighted_pseudo_inverse(J: FloatArray, W: FloatArray, C: FloatArray) -> FloatArray:
    """``J# = (J^T C J + W)^-1 J^T C`` (slide 2:26).

    Args:
        J: (d, n) Jacobian.
        W: (n, n) positive-definite metric on joint space.
        C: (d, d) positive-definite task precision.

    Raises:
        ShapeError, NotFiniteError: wrong shapes, NaN or inf.
        InvalidInputError: ``W`` or ``C`` not symmetric positive definite.
    """
    J = _jacobian(J)
    d, n = J.shape
    W = _metric(W, n, "W", definite=True)
    C = _metric(C, d, "C", definite=True)
    return _solve(J.T @ C @ J + W, J.T @ C, "J^T C J + W")


def weighted_pseudo_inverse_woodbury(J: FloatArray, W: FloatArray, C: FloatArray) -> FloatArray:
    """``J# = W^-1 J^T (J W^-1 J^T + C^-1)^-1``, equal to :func:`weighted_pseudo_inverse`.

    Arguments and errors as :func:`weighted_pseudo_inverse`.
    """
    J = _jacobian(J)
    d, n = J.shape
    W = _metric(W, n, "W", definite=True)
    C = _metric(C, d, "C", definite=True)
    Winv_Jt = _solve(W, J.T, "W")
    inner = _finite(J @ Winv_Jt + np.linalg.inv(C), "J W^-1 J^T + C^-1")
    return _finite(np.asarray(Winv_Jt @ np.linalg.inv(inner)), "J#")


def damped_pseudo_inverse(J: FloatArray, damping: float) -> FloatArray:
    """Singularity-robust ``J^T (J J^T + lambda^2 I)^-1`` (C = I / lambda^2, W = I).

    Args:
        J: (d, n) Jacobian.
        damping: ``lambda >= 0`` (0: the pseudo-inverse of a full-row-rank ``J``).

    Raises:
        ShapeError, NotFiniteError, InvalidInputError: a bad ``J``, ``damping`` negative or
            not finite, ``J J^T`` singular with ``damping = 0``.
    """
    J = _jacobian(J)
    lam = check_positive(damping, "damping", strict=False)
    return _solve(J @ J.T + lam**2 * np.eye(J.shape[0]), J, "J J^T + damping^2 I").T


def pseudo_inverse(J: FloatArray, rcond: float = 1e-10) -> FloatArray:
    """Moore-Penrose pseudo-inverse ``J^T (J J^T)^-1`` (the limit C -> inf, W = I).

    ``rcond``: singular values below ``rcond`` times the largest count as zero (>= 0).
    """
    J = _jacobian(J)
    rcond = check_positive(rcond, "rcond", strict=False)
    return _finite(np.asarray(np.linalg.pinv(J, rcond=rcond)), "J^+")


def nullspace_projector(J: FloatArray, J_sharp: FloatArray) -> FloatArray:
    """``I - J# J``: joint motions that (to first order) do not change the task.

    ``J``: (d, n); ``J_sharp``: (n, d), a generalized inverse of ``J``.
    """
    J = _jacobian(J)
    J_sharp = as_matrix(J_sharp, (J.shape[1], J.shape[0]), "J_sharp")
    return _finite(np.asarray(np.eye(J.shape[1]) - J_sharp @ J), "I - J# J")


def ik_step(
    J: FloatArray,
    y_error: FloatArray,
    W: FloatArray,
    C: FloatArray,
    h: FloatArray | None = None,
) -> FloatArray:
    """``dq = J# (y* - y) + (I - J# J) h`` (slide 2:29).

    ``J#`` is :func:`weighted_pseudo_inverse`.

    Args:
        J: task Jacobian at the linearization point.
        y_error: ``y* - phi(q')``.
        W, C: metrics as in :func:`weighted_pseudo_inverse`.
        h: nullspace motion (``q0 - q'``); zero if omitted.
    """
    J = _jacobian(J)
    d, n = J.shape
    err = as_vector(y_error, d, "y_error")
    Js = weighted_pseudo_inverse(J, W, C)
    dq = Js @ err
    if h is not None:
        dq = dq + nullspace_projector(J, Js) @ as_vector(h, n, "h")
    return _finite(np.asarray(dq), "dq")


def stacked_step(
    jacobians: Sequence[FloatArray],
    errors: Sequence[FloatArray],
    precisions: Sequence[float],
    W: FloatArray,
) -> FloatArray:
    """Multi-task step ``dq = -(J^T J + W)^-1 J^T Phi`` with ``Phi_i = sqrt(rho_i)(phi_i - y_i*)``.

    Args:
        jacobians: task Jacobians ``J_i``.
        errors: ``phi_i(q0) - y_i*``.
        precisions: ``rho_i``.
        W: joint-space metric (symmetric positive semi-definite; ``J^T J + W`` invertible).
    """
    Js, es, rhos = _levels(jacobians, errors, precisions, "errors")
    W = _metric(W, Js[0].shape[1], "W", definite=False)
    J = np.vstack([np.sqrt(r) * Ji for Ji, r in zip(Js, rhos)])
    Phi = np.concatenate([np.sqrt(r) * e for e, r in zip(es, rhos)])
    return -_solve(J.T @ J + W, _finite(J.T @ Phi, "J^T Phi"), "J^T J + W")


def _levels(
    jacobians: Sequence[Any], vectors: Sequence[Any], precisions: Sequence[Any] | None, what: str
) -> tuple[list[FloatArray], list[FloatArray], list[float]]:
    """The tasks' Jacobians (d_i, n), their vectors (d_i,) and precisions (> 0), checked."""
    if isinstance(jacobians, np.ndarray) and jacobians.ndim == 2:
        raise InvalidInputError("jacobians must be a sequence of matrices, e.g. [J1, J2]")
    Js = list(jacobians)
    vs = list(vectors)
    if not Js:
        raise InvalidInputError("at least one task is needed (jacobians is empty)")
    if len(vs) != len(Js) or (precisions is not None and len(precisions) != len(Js)):
        raise InvalidInputError(
            f"one entry per task: {len(Js)} jacobians, {len(vs)} {what}"
            + ("" if precisions is None else f", {len(precisions)} precisions")
        )
    n = _jacobian(Js[0], "jacobians[0]").shape[1]
    Js = [_jacobian(J, f"jacobians[{i}]", n) for i, J in enumerate(Js)]
    vs = [as_vector(v, J.shape[0], f"{what}[{i}]") for i, (v, J) in enumerate(zip(vs, Js))]
    rhos = [
        check_positive(r, f"precisions[{i}]") for i, r in enumerate(precisions or [1.0] * len(Js))
    ]
    return Js, vs, rhos


def hierarchical_step_regularized(
    jacobians: Sequence[FloatArray],
    targets: Sequence[FloatArray],
    precisions: Sequence[float],
    W: FloatArray,
    a: FloatArray,
) -> FloatArray:
    """Slide 2:43 for any number of levels (level 1 = highest priority).

    Minimizes ``|q - a|^2_W + sum_i rho_i |J_i q - y_i|^2`` by the nested formula
    ``q* = J1# y1 + (I - J1# J1)[J2# y2 + (I - J2# J2)[... a]]`` with
    ``Jk# = (W_k / rho_k + Jk^T Jk)^-1 Jk^T`` and ``W_K = W``,
    ``W_k = W_{k+1} + rho_{k+1} J_{k+1}^T J_{k+1}`` (each level's metric carries the lower ones).
    With ``rho_1 >> rho_2 >> ...`` this tends to the strict hierarchy.
    """
    jacobians, targets, precisions = _levels(jacobians, targets, precisions, "targets")
    n = jacobians[0].shape[1]
    W = _metric(W, n, "W", definite=False)
    a = as_vector(a, n, "a")
    K = len(jacobians)
    metrics = [W] * K
    for k in range(K - 2, -1, -1):
        Jn = jacobians[k + 1]
        metrics[k] = metrics[k + 1] + precisions[k + 1] * Jn.T @ Jn
    q = np.asarray(a, dtype=float)
    for k in range(K - 1, -1, -1):
        Jk = jacobians[k]
        Js = _solve(
            metrics[k] / precisions[k] + Jk.T @ Jk, Jk.T, f"level {k + 1}'s W_k / rho_k + J^T J"
        )
        q = Js @ targets[k] + (np.eye(len(q)) - Js @ Jk) @ q
    return _finite(q, "q")


def hierarchical_step_exact(
    jacobians: Sequence[FloatArray], targets: Sequence[FloatArray], tolerance: float = 1e-9
) -> FloatArray:
    """Strict hierarchy, least-norm: ``q_k = q_{k-1} + (J_k N_{k-1})^+ (y_k - J_k q_{k-1})``.

    ``N_k = N_{k-1} - (J_k N_{k-1})^+ (J_k N_{k-1})`` (recursive nullspace projection). The
    lexicographic optimum of ``|J_1 q - y_1|^2, |J_2 q - y_2|^2, ...``, then ``|q|^2``.
    Singular values below the absolute ``tolerance`` count as zero (directions already used
    by higher levels leave round-off in ``J_k N_{k-1}`` that must not be inverted).
    """
    jacobians, targets, _ = _levels(jacobians, targets, None, "targets")
    tol = check_positive(tolerance, "tolerance", strict=False)
    n = jacobians[0].shape[1]
    q = np.zeros(n)
    N = np.eye(n)
    for Jk, yk in zip(jacobians, targets):
        JN = Jk @ N
        U, s, Vt = np.linalg.svd(JN, full_matrices=False)
        keep = s > tol
        JN_pinv = (Vt[keep].T / s[keep]) @ U[:, keep].T
        q = q + JN_pinv @ (yk - Jk @ q)
        N = N - JN_pinv @ JN
    return _finite(q, "q")
