"""Kinematics of points and vectors attached to frames (slides 2:18-2:19, 2:46-2:47).

With ``J = [J_lin; J_ang]`` the LOCAL_WORLD_ALIGNED frame Jacobian and ``r = R v`` the
offset in world coordinates, a point ``p = o + r`` has ``J_p = J_lin - [r]x J_ang`` (column k
is ``J_lin[:, k] + omega_k x r``) and a vector ``u = R v`` has ``J_u = -[u]x J_ang``.
Drift at zero joint acceleration: ``a_p = a_o + alpha x r + omega x (omega x r)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError
from taskspace.model.state import State


def nonzero_vector(x: Any, name: str) -> FloatArray:
    """A finite 3-vector of norm > 1e-12 (a zero direction makes the feature constant)."""
    v = as_vector(x, 3, name)
    if not math.hypot(*v) > 1e-12:  # (v @ v overflowed with a RuntimeWarning for 1e300)
        raise InvalidInputError(
            f"{name} must be a non-zero direction, got {v.tolist()} (a zero vector makes the "
            "feature identically zero)"
        )
    return v


def unit_vector(x: Any, name: str) -> FloatArray:
    """:func:`nonzero_vector` scaled to unit length (directions of alignment features)."""
    v = nonzero_vector(x, name)
    scale = float(np.abs(v).max())  # |v / scale| in [1, sqrt 3]: no overflow for |v| ~ 1e300
    v = v / scale
    return v / float(np.sqrt(v @ v))


def cross_columns(J_ang: FloatArray, r: FloatArray) -> FloatArray:
    """Matrix whose column k is ``J_ang[:, k] x r`` (i.e. ``-[r]x J_ang``)."""
    # Explicit formula: faster than np.cross for small matrices.
    wx, wy, wz = J_ang[0], J_ang[1], J_ang[2]
    return np.vstack((wy * r[2] - wz * r[1], wz * r[0] - wx * r[2], wx * r[1] - wy * r[0]))


def point_position(state: State, frame_id: int, offset: FloatArray | None) -> FloatArray:
    """World position of ``offset`` (frame coordinates) on frame ``frame_id`` [m]."""
    M = state.frame_placement(frame_id)
    if offset is None:
        return np.array(M.translation)
    return np.asarray(M.rotation @ offset + M.translation)


def point_jacobian(state: State, frame_id: int, offset: FloatArray | None) -> FloatArray:
    """3 x nv Jacobian of a point attached to a frame."""
    J = state.frame_jacobian(frame_id)
    if offset is None:
        return J[:3]
    r = state.frame_placement(frame_id).rotation @ offset
    return J[:3] + cross_columns(J[3:], r)


def point_velocity(state: State, frame_id: int, offset: FloatArray | None) -> FloatArray:
    """World velocity of a point attached to a frame [m/s]."""
    return point_jacobian(state, frame_id, offset) @ state.v


def point_drift(state: State, frame_id: int, offset: FloatArray | None) -> FloatArray:
    """Acceleration of a point attached to a frame at zero joint acceleration [m/s^2]."""
    acc = state.frame_drift(frame_id)
    if offset is None:
        return acc[:3].copy()
    r = state.frame_placement(frame_id).rotation @ offset
    omega = state.frame_velocity(frame_id)[3:]
    return np.asarray(acc[:3] + np.cross(acc[3:], r) + np.cross(omega, np.cross(omega, r)))


def vector_value(state: State, frame_id: int, vector: FloatArray) -> FloatArray:
    """World coordinates of a vector attached to a frame."""
    return np.asarray(state.frame_placement(frame_id).rotation @ vector)


def vector_jacobian(state: State, frame_id: int, vector: FloatArray) -> FloatArray:
    """3 x nv Jacobian of a vector attached to a frame."""
    u = vector_value(state, frame_id, vector)
    return cross_columns(state.frame_jacobian(frame_id)[3:], u)


def vector_velocity(state: State, frame_id: int, vector: FloatArray) -> FloatArray:
    """Time derivative of an attached vector, ``omega x u``."""
    u = vector_value(state, frame_id, vector)
    omega = state.frame_velocity(frame_id)[3:]
    return np.cross(omega, u)


def vector_drift(state: State, frame_id: int, vector: FloatArray) -> FloatArray:
    """Second time derivative of an attached vector at zero joint acceleration."""
    u = vector_value(state, frame_id, vector)
    alpha = state.frame_drift(frame_id)[3:]
    omega = state.frame_velocity(frame_id)[3:]
    return np.asarray(np.cross(alpha, u) + np.cross(omega, np.cross(omega, u)))
