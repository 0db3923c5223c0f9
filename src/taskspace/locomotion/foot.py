"""Foot contact geometry: the sole polygon (surface contact) or contact points of a foot.

A foot is a frame of the robot plus the contact vertices expressed in that frame. A flat sole
is a surface contact whose support region is the convex hull of its corners; a foot that
touches the ground at a few points (point contacts) is described by those points. Either way
the support region of the foot is the convex hull of the vertices mapped to the world,

    p_i^W = R_W^F p_i^F + t_W^F.

Registered feet: Talos (``left_sole_link``/``right_sole_link``: a 0.221 m x 0.134 m rectangle
from the collision mesh of ``leg_*_6_link``, sole plane at the frame origin) and G1
(``left_ankle_roll_link``/``right_ankle_roll_link``: the four contact spheres of the collision
model, radius 5 mm, whose lowest points are the point contacts, 35 mm below the frame).

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_matrix
from taskspace.errors import InvalidInputError, UnknownNameError


class ContactKind(enum.Enum):
    """How a foot touches the ground."""

    SURFACE = "surface"
    """A flat sole; the vertices are the corners of the sole polygon."""
    POINTS = "points"
    """A few point contacts; the vertices are the contact points."""


@dataclass(frozen=True, kw_only=True)
class FootGeometry:
    """The contact vertices of a foot in its frame.

    Attributes:
        frame: name of the foot frame in the robot model.
        vertices: (k, 3) contact vertices in the foot frame [m].
        kind: surface (sole corners) or point contacts.
    """

    frame: str
    vertices: FloatArray
    kind: ContactKind = ContactKind.SURFACE

    def __post_init__(self) -> None:
        if not isinstance(self.frame, str) or not self.frame:
            raise InvalidInputError(
                "frame must be the name of a frame of the robot (a non-empty str), "
                f"got {self.frame!r}"
            )
        v = as_matrix(self.vertices, (None, 3), "vertices")
        if v.shape[0] < 1:
            raise InvalidInputError("a foot needs at least one contact vertex")
        object.__setattr__(self, "vertices", v.copy())
        self.vertices.flags.writeable = False

    @staticmethod
    def rectangle(
        frame: str, x_min: float, x_max: float, y_min: float, y_max: float, z: float = 0.0
    ) -> FootGeometry:
        """A rectangular sole ``[x_min, x_max] x [y_min, y_max]`` at height ``z`` [m]."""
        if not (x_min < x_max and y_min < y_max):
            raise InvalidInputError(
                f"the sole rectangle needs x_min < x_max and y_min < y_max, got "
                f"x [{x_min}, {x_max}], y [{y_min}, {y_max}]"
            )
        corners = [[x_min, y_min, z], [x_max, y_min, z], [x_max, y_max, z], [x_min, y_max, z]]
        return FootGeometry(frame=frame, vertices=np.array(corners), kind=ContactKind.SURFACE)

    @property
    def center(self) -> FloatArray:
        """Mean of the vertices in the foot frame [m]."""
        return np.asarray(self.vertices.mean(axis=0))

    def vertices_in_world(self, placement: pin.SE3) -> FloatArray:
        """(k, 3) vertices in the world: ``p^W = R p^F + t``."""
        return np.asarray(self.vertices @ placement.rotation.T + placement.translation)


_TALOS_SOLE = (-0.1163, 0.1046, -0.0672, 0.0672)
_G1_POINTS = np.array(
    [[-0.05, 0.025, -0.035], [-0.05, -0.025, -0.035], [0.12, 0.03, -0.035], [0.12, -0.03, -0.035]]
)


def _registry() -> dict[str, dict[str, FootGeometry]]:
    return {
        "talos": {
            side: FootGeometry.rectangle(f"{side}_sole_link", *_TALOS_SOLE)
            for side in ("left", "right")
        },
        "g1": {
            side: FootGeometry(
                frame=f"{side}_ankle_roll_link", vertices=_G1_POINTS, kind=ContactKind.POINTS
            )
            for side in ("left", "right")
        },
    }


FOOT_ROBOTS = ("talos", "g1")
"""Robots whose feet are registered (see :func:`robot_feet`)."""


def robot_feet(robot_name: str) -> dict[str, FootGeometry]:
    """The registered feet of a robot, by side (``"left"``, ``"right"``).

    Raises:
        UnknownNameError: the robot has no registered feet (the message lists those that do).
    """
    reg = _registry()
    if robot_name not in reg:
        raise UnknownNameError("robot", robot_name, reg)
    return reg[robot_name]


def foot_placement(robot: Any, q: Any, foot: FootGeometry) -> pin.SE3:
    """World placement of the foot frame at configuration ``q`` (a :class:`Robot` method)."""
    return robot.frame_placement(q, foot.frame)  # type: ignore[no-any-return]
