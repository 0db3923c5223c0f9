"""A two-body robot on a chosen root joint (spherical, planar, free flyer...): Lie-group tests."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.model import Robot


def two_body_robot(root: pin.JointModel, name: str, gravity: bool = True) -> Robot:
    """A box on ``root`` (unbounded) and a second box on a revolute elbow; no geometry."""
    model = pin.Model()
    inf = np.full(root.nq, np.inf)
    j1 = model.addJoint(
        0,
        root,
        pin.SE3.Identity(),
        "root",
        np.full(root.nv, 10.0),
        np.full(root.nv, 5.0),
        -inf,
        inf,
    )
    body = pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3)
    model.appendBodyToJoint(j1, body, pin.SE3(np.eye(3), np.array([0.05, 0.02, -0.1])))
    j2 = model.addJoint(
        j1,
        pin.JointModelRY(),
        pin.SE3(np.eye(3), np.array([0.3, 0.1, 0.0])),
        "elbow",
        np.ones(1),
        np.full(1, 5.0),
        -np.full(1, 10.0),
        np.full(1, 10.0),
    )
    model.appendBodyToJoint(j2, body, pin.SE3.Identity())
    if not gravity:
        model.gravity = pin.Motion.Zero()
    empty = pin.GeometryModel()
    return Robot(model, empty, empty.copy(), name=name)
