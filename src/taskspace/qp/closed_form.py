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
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from taskspace._validation import FloatArray


def weighted_pseudo_inverse(J: FloatArray, W: FloatArray, C: FloatArray) -> FloatArray:
    """``J# = (J^T C J + W)^-1 J^T C`` (slide 2:26).

    Args:
        J: (d, n) Jacobian.
        W: (n, n) positive-definite metric on joint space.
        C: (d, d) positive-definite task precision.
    """
    return np.asarray(np.linalg.solve(J.T @ C @ J + W, J.T @ C))


def weighted_pseudo_inverse_woodbury(J: FloatArray, W: FloatArray, C: FloatArray) -> FloatArray:
    """``J# = W^-1 J^T (J W^-1 J^T + C^-1)^-1``, equal to :func:`weighted_pseudo_inverse`."""
    Winv_Jt = np.linalg.solve(W, J.T)
    return np.asarray(Winv_Jt @ np.linalg.inv(J @ Winv_Jt + np.linalg.inv(C)))


def damped_pseudo_inverse(J: FloatArray, damping: float) -> FloatArray:
    """Singularity-robust ``J^T (J J^T + lambda^2 I)^-1`` (C = I / lambda^2, W = I)."""
    return np.asarray(J.T @ np.linalg.inv(J @ J.T + damping**2 * np.eye(J.shape[0])))


def pseudo_inverse(J: FloatArray, rcond: float = 1e-10) -> FloatArray:
    """Moore-Penrose pseudo-inverse ``J^T (J J^T)^-1`` (the limit C -> inf, W = I)."""
    return np.asarray(np.linalg.pinv(J, rcond=rcond))


def nullspace_projector(J: FloatArray, J_sharp: FloatArray) -> FloatArray:
    """``I - J# J``: joint motions that (to first order) do not change the task."""
    return np.asarray(np.eye(J.shape[1]) - J_sharp @ J)


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
    Js = weighted_pseudo_inverse(J, W, C)
    dq = Js @ y_error
    if h is not None:
        dq = dq + nullspace_projector(J, Js) @ h
    return np.asarray(dq)


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
        W: joint-space metric.
    """
    J = np.vstack([np.sqrt(r) * Ji for Ji, r in zip(jacobians, precisions)])
    Phi = np.concatenate([np.sqrt(r) * e for e, r in zip(errors, precisions)])
    return np.asarray(-np.linalg.solve(J.T @ J + W, J.T @ Phi))


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
    K = len(jacobians)
    metrics = [W] * K
    for k in range(K - 2, -1, -1):
        Jn = jacobians[k + 1]
        metrics[k] = metrics[k + 1] + precisions[k + 1] * Jn.T @ Jn
    q = np.asarray(a, dtype=float)
    for k in range(K - 1, -1, -1):
        Jk = jacobians[k]
        Js = np.linalg.solve(metrics[k] / precisions[k] + Jk.T @ Jk, Jk.T)
        q = Js @ targets[k] + (np.eye(len(q)) - Js @ Jk) @ q
    return q


def hierarchical_step_exact(
    jacobians: Sequence[FloatArray], targets: Sequence[FloatArray], tolerance: float = 1e-9
) -> FloatArray:
    """Strict hierarchy, least-norm: ``q_k = q_{k-1} + (J_k N_{k-1})^+ (y_k - J_k q_{k-1})``.

    ``N_k = N_{k-1} - (J_k N_{k-1})^+ (J_k N_{k-1})`` (recursive nullspace projection). The
    lexicographic optimum of ``|J_1 q - y_1|^2, |J_2 q - y_2|^2, ...``, then ``|q|^2``.
    Singular values below the absolute ``tolerance`` count as zero (directions already used
    by higher levels leave round-off in ``J_k N_{k-1}`` that must not be inverted).
    """
    n = jacobians[0].shape[1]
    q = np.zeros(n)
    N = np.eye(n)
    for Jk, yk in zip(jacobians, targets):
        JN = Jk @ N
        U, s, Vt = np.linalg.svd(JN, full_matrices=False)
        keep = s > tolerance
        JN_pinv = (Vt[keep].T / s[keep]) @ U[:, keep].T
        q = q + JN_pinv @ (yk - Jk @ q)
        N = N - JN_pinv @ JN
    return q
