"""The grasp matrix ``G`` and the hand Jacobian ``J_h`` (Murray, Li and Sastry, ch. 5).

For contact ``i`` with frame ``R_i`` at ``p_i``, the wrench on the object of the contact
force ``f_i^c`` (in the contact frame, the components the contact model transmits) is
``w_i = G_i f_i^c`` with ``G_i = [[R_i, 0], [(p_i - c)^ R_i, R_i]] B_i`` where ``B_i`` selects
the transmitted components (normal only; the three forces; forces and torsion). ``G`` stacks
the ``G_i`` side by side: ``w = G f``. Dually, ``G^T`` maps the object's twist (linear velocity
at ``c`` and angular velocity) to the velocities of the contact points in the contact frames,
and the hand Jacobian maps joint velocities to the same: ``J_h qdot = G^T V_object`` is the
grasp constraint.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace.errors import InvalidInputError
from taskspace.grasping.contact import (
    ContactType,
    GraspContact,
    _skew,
    check_center,
    check_contacts,
)
from taskspace.model import Robot, State

FloatArray = npt.NDArray[np.float64]


def _selection(contact: GraspContact) -> FloatArray:
    """``B_i``: the transmitted components of the 6-D contact wrench (local frame)."""
    if contact.type is ContactType.FRICTIONLESS:
        return np.eye(6)[:, [2]]
    if contact.type is ContactType.POINT_FRICTION:
        return np.eye(6)[:, :3]
    return np.eye(6)[:, [0, 1, 2, 5]]


def grasp_matrix(contacts: list[GraspContact], center: FloatArray | None = None) -> FloatArray:
    """``G`` of shape ``(6, sum_i m_i)``: object wrench (force; moment about ``center``) ``= G f``.

    Args:
        contacts: the contacts (positions in the object frame [m]).
        center: the point the moments are taken about [m] (default: the origin).
    """
    contacts = check_contacts(contacts)
    c = check_center(center)
    blocks = []
    for contact in contacts:
        R = contact.rotation
        adjoint = np.zeros((6, 6))
        adjoint[:3, :3] = R
        adjoint[3:, 3:] = R
        adjoint[3:, :3] = _skew(contact.position - c) @ R
        blocks.append(adjoint @ _selection(contact))
    return np.hstack(blocks)


def hand_jacobian(
    robot: Robot, state: State, contacts: list[GraspContact], object_pose: pin.SE3
) -> FloatArray:
    """The hand Jacobian ``J_h`` of shape ``(sum_i m_i, nv)``.

    Rows: the velocities of the finger points at the contacts in the contact frames (and
    the spin about the normal for soft fingers), per joint velocity.

    Args:
        robot: the hand (or arm and hand).
        state: its state (kinematics computed).
        contacts: contacts in the object frame; each names the finger ``frame`` touching.
        object_pose: the object's pose in the world.
    """
    contacts = check_contacts(contacts)
    if not isinstance(object_pose, pin.SE3):
        raise InvalidInputError(
            f"object_pose must be a pinocchio.SE3, got {type(object_pose).__name__}"
        )
    rows = []
    for contact in contacts:
        if contact.frame is None:
            raise InvalidInputError("hand_jacobian needs the finger frame of every contact")
        fid = robot.frame_id(contact.frame)
        J = pin.getFrameJacobian(robot._model, state.data, fid, pin.LOCAL_WORLD_ALIGNED)
        p_world = object_pose.act(contact.position)
        offset = p_world - state.data.oMf[fid].translation
        Jp = J[:3] - _skew(offset) @ J[3:]  # velocity of the finger point at the contact
        R_world = object_pose.rotation @ contact.rotation
        local = np.vstack([R_world.T @ Jp, R_world.T @ J[3:]])
        rows.append(_selection(contact).T @ local)
    return np.vstack(rows)
