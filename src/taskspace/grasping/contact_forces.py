"""Contact forces that hold a grasped object against an external wrench, as a QP.

With each contact force a non-negative combination of its cone edges, ``f_i = E_i lam_i``,
``lam_i >= 0``, the forces that balance an external wrench ``w_ext`` with the least effort are

    min_lam  |f|^2 + eps |lam|^2   s.t.  W^T lam = -w_ext,  lam >= 0,
             -tau_max <= J_h^T f <= tau_max  (when the hand Jacobian is given),

where ``W`` holds the primitive wrenches (moments in N m). The part of ``f`` in the null space
of the grasp matrix is the internal (squeezing) force. Solved with taskspace's QP layer.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own. A ``solver`` passed to
:func:`balance_forces` is used as given: do not share one between threads unless
:class:`~taskspace.qp.QPSolver` says it may be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_float_array, as_matrix, as_vector
from taskspace.errors import InfeasibleError, InvalidInputError
from taskspace.grasping.contact import (
    GraspContact,
    check_contacts,
    check_edges,
    contact_edges,
    nonnegative,
    primitive_wrenches,
)
from taskspace.qp import INF, QPProblem, QPResult, QPSolver, QPSolverOptions

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ContactForces:
    """Forces that balance an external wrench.

    Attributes:
        forces: contact forces in the world, shape ``(n_contacts, 3)`` [N].
        torsion: torsional moments about the normals [N m] (zero unless soft fingers).
        coefficients: the edge coefficients ``lam`` (all >= 0).
        internal: the internal part of the stacked forces (null space of the balance map).
        qp: the QP result (status, KKT residuals).
    """

    forces: FloatArray
    torsion: FloatArray
    coefficients: FloatArray
    internal: FloatArray
    qp: QPResult


def edge_matrix(contacts: list[GraspContact], edges: int) -> tuple[FloatArray, list[int]]:
    """``E`` of shape ``(4 n, K)``: each contact's (force, torsion) per edge coefficient."""
    columns, owner = [], []
    for i, contact in enumerate(contacts):
        for g in contact_edges(contact, edges):
            col = np.zeros(4 * len(contacts))
            col[4 * i : 4 * i + 4] = g
            columns.append(col)
            owner.append(i)
    return np.array(columns).T, owner


def balance_forces(
    contacts: list[GraspContact],
    external_wrench: FloatArray,
    *,
    edges: int = 8,
    hand_jacobian: FloatArray | None = None,
    torque_limits: FloatArray | None = None,
    regularization: float = 1e-9,
    solver: QPSolver | None = None,
) -> ContactForces:
    """The least-effort contact forces that hold the object against ``external_wrench``.

    Args:
        contacts: the grasp (positions in the frame the wrench is expressed in [m]).
        external_wrench: force [N] and moment about the origin [N m] acting on the object.
        edges: edges of each linearized friction cone.
        hand_jacobian: optional ``J`` of shape ``(3 n, nv)`` mapping joint velocities to the
            world velocities of the contact points (stacked), so joint torques are ``J^T f``.
        torque_limits: ``tau_max`` per joint [N m] (with ``hand_jacobian``).
        regularization: ``eps`` on the edge coefficients (makes the QP strictly convex).
        solver: the QP solver (default: taskspace's, proxsuite).

    Raises:
        InfeasibleError: when no forces inside the cones (and torque limits) balance the wrench.
    """
    contacts = check_contacts(contacts)
    edges = check_edges(edges)
    w = as_float_array(external_wrench, "external_wrench").reshape(-1)
    if w.shape != (6,) or not np.all(np.isfinite(w)):
        raise InvalidInputError(f"external_wrench must be 6 finite numbers, got {w}")
    regularization = nonnegative(regularization, "regularization")
    if hand_jacobian is None and torque_limits is not None:
        raise InvalidInputError("torque_limits given without hand_jacobian (J^T f are the torques)")
    W, _ = primitive_wrenches(contacts, edges=edges, torque_scale=1.0)
    E, _ = edge_matrix(contacts, edges)
    k = W.shape[0]
    n = len(contacts)
    F = E.reshape(n, 4, k)[:, :3, :].reshape(3 * n, k)  # stacked forces per coefficient
    H = F.T @ F + regularization * np.eye(k)
    C = np.zeros((0, k))
    lo = hi = np.zeros(0)
    if hand_jacobian is not None:
        J = as_matrix(hand_jacobian, (3 * n, None), "hand_jacobian")
        if torque_limits is None:
            raise InvalidInputError("hand_jacobian given without torque_limits")
        tau = as_vector(
            as_float_array(torque_limits, "torque_limits").reshape(-1), J.shape[1], "torque_limits"
        )
        if np.any(tau < 0):
            raise InvalidInputError(f"torque_limits must be {J.shape[1]} numbers >= 0")
        C = J.T @ F
        lo, hi = -tau, tau
    problem = QPProblem(
        H=H,
        g=np.zeros(k),
        A=W.T.copy(),
        b=-w,
        C=C,
        l=lo,
        u=hi,
        lb=np.zeros(k),
        ub=np.full(k, INF),
        convex=True,  # F^T F + regularization I
    )
    result = (solver or QPSolver(QPSolverOptions())).solve(problem)
    if not result.success:
        raise InfeasibleError(
            "no contact forces inside the friction cones"
            + (" and torque limits" if hand_jacobian is not None else "")
            + f" balance the wrench {w.tolist()} ({result.status.name})"
        )
    lam = result.x
    stacked = E @ lam
    forces = stacked.reshape(n, 4)[:, :3]
    torsion = stacked.reshape(n, 4)[:, 3]
    Wf = W.T @ np.linalg.pinv(F)  # balance map on stacked forces (for the internal part)
    internal = F @ lam - np.linalg.pinv(Wf) @ (Wf @ (F @ lam))
    return ContactForces(forces, torsion, lam, internal, result)
