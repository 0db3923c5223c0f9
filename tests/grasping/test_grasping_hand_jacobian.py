"""The hand Jacobian of a real multi-finger hand against finite differences (Pinocchio only)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.grasping import ContactType, GraspContact, hand_jacobian
from taskspace.model import Robot


def test_allegro_hand_jacobian_matches_finite_differences() -> None:
    robot = Robot.load("allegro_right_hand")
    model = robot.model
    tips = [f.name for f in model.frames if f.name.endswith("tip") or "tip" in f.name][:3]
    assert len(tips) == 3, [f.name for f in model.frames]
    rng = np.random.default_rng(0)
    q = robot.random_configuration(rng)
    state = robot.state(q)
    object_pose = pin.SE3(pin.exp3(rng.standard_normal(3)), rng.standard_normal(3) * 0.1)
    contacts = []
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    for k, name in enumerate(tips):
        fid = model.getFrameId(name)
        offset = rng.standard_normal(3) * 0.005  # a point of the fingertip near the frame
        p_world = data.oMf[fid].act(offset)
        kind = [ContactType.POINT_FRICTION, ContactType.SOFT_FINGER, ContactType.FRICTIONLESS][k]
        contacts.append(
            GraspContact(
                object_pose.actInv(p_world),
                rng.standard_normal(3),
                type=kind,
                torsion=0.01,
                frame=name,
            )
        )
    J = hand_jacobian(robot, state, contacts, object_pose)
    # Finite differences: the finger point (fixed on its link) moving with q, and the link's
    # rotation for the spin, both expressed in the contact frames.
    h = 1e-6
    columns = []
    for j in range(model.nv):
        dq = np.zeros(model.nv)
        dq[j] = h
        rows = []
        plus, minus = model.createData(), model.createData()
        pin.framesForwardKinematics(model, plus, pin.integrate(model, q, dq))
        pin.framesForwardKinematics(model, minus, pin.integrate(model, q, -dq))
        for c in contacts:
            fid = model.getFrameId(c.frame)
            local_point = data.oMf[fid].actInv(object_pose.act(c.position))
            v = (plus.oMf[fid].act(local_point) - minus.oMf[fid].act(local_point)) / (2 * h)
            w = pin.log3(plus.oMf[fid].rotation @ minus.oMf[fid].rotation.T) / (2 * h)
            R = object_pose.rotation @ c.rotation
            local = np.hstack([R.T @ v, R.T @ w])
            sel = {
                ContactType.FRICTIONLESS: [2],
                ContactType.POINT_FRICTION: [0, 1, 2],
                ContactType.SOFT_FINGER: [0, 1, 2, 5],
            }[c.type]
            rows.append(local[sel])
        columns.append(np.hstack(rows))
    assert np.allclose(J, np.column_stack(columns), atol=1e-7)
