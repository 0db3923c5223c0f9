"""Collision distances and the penetration of collision limits (slide 2:53), from coal."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import UnknownNameError
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


def _cross(a: FloatArray, b: FloatArray) -> tuple[float, float, float]:
    """``a x b`` for 3-vectors (np.cross costs ~10 us per call on small inputs)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


class CollisionDistance(Feature):
    """Signed distances ``d_k`` of collision pairs (negative when penetrating) [m].

    For pair k with nearest points ``p_a`` (on geometry a) and ``p_b`` and unit normal ``n``
    (from a to b), ``d_k = n^T (p_b - p_a)`` and its Jacobian row is
    ``n^T (J_pos(p_b) - J_pos(p_a))`` with the points held fixed on their bodies (exact for
    the separation of convex shapes). Obstacles have zero Jacobian. The drift uses the same
    rigid-witness-point approximation.

    Distance queries on meshes are slow (ms); load robots with ``convex_collision=True``.

    Args:
        robot: the robot.
        pairs: (geometry name, geometry name) pairs to include (default: every checked pair).
    """

    def __init__(self, robot: Robot, pairs: Sequence[tuple[str, str]] | None = None) -> None:
        super().__init__(robot, "collision_distance")
        all_pairs = robot.collision_pairs
        if pairs is None:
            self.pair_indices = np.arange(len(all_pairs))
        else:
            lookup = {p: k for k, p in enumerate(all_pairs)}
            lookup.update({(b, a): k for (a, b), k in list(lookup.items())})
            idx = []
            for pair in pairs:
                key = (pair[0], pair[1])
                if key not in lookup:
                    valid = [f"{a}|{b}" for a, b in all_pairs]
                    raise UnknownNameError("collision pair", f"{pair[0]}|{pair[1]}", valid)
                idx.append(lookup[key])
            self.pair_indices = np.asarray(idx, dtype=int)
        self.dim = len(self.pair_indices)
        objs = robot.collision_model.geometryObjects
        cps = robot.collision_model.collisionPairs
        self._joints = [
            (int(objs[cps[int(k)].first].parentJoint), int(objs[cps[int(k)].second].parentJoint))
            for k in self.pair_indices
        ]
        self.pair_names = [all_pairs[k] for k in self.pair_indices]
        self._pairs = [int(k) for k in self.pair_indices]

    def _results(self, state: State) -> list:  # type: ignore[type-arg]
        state.compute_distances()
        res = state.collision_data.distanceResults
        return [res[k] for k in self._pairs]

    def value(self, state: State) -> FloatArray:
        """Signed distances [m]."""
        self._check_state(state)
        return np.array([r.min_distance for r in self._results(state)])

    def jacobian(self, state: State, rows: npt.NDArray[Any] | None = None) -> FloatArray:
        """Dim x nv Jacobian (only the ``rows`` selected by index or mask, if given).

        Row k is ``[n; p_b x n]^T J_b - [n; p_a x n]^T J_a`` with ``J`` the WORLD joint
        Jacobians (the velocity of a point ``p`` is ``v_O + omega x p`` and
        ``n . (omega x p) = omega . (p x n)``).
        """
        self._check_state(state)
        results = self._results(state)
        selected = np.arange(self.dim) if rows is None else np.arange(self.dim)[rows]
        J = np.zeros((len(selected), self.robot.nv))
        cache: dict[int, FloatArray] = {}

        def joint_jacobian(joint: int) -> FloatArray:
            Jw = cache.get(joint)
            if Jw is None:
                Jw = state.joint_jacobian_world(joint)
                cache[joint] = Jw
            return Jw

        w = np.empty(6)
        for out_row, k in enumerate(selected):
            res = results[k]
            ja, jb = self._joints[k]
            n = np.asarray(res.normal)
            w[:3] = n
            if jb:
                w[3:] = _cross(res.getNearestPoint2(), n)
                J[out_row] += w @ joint_jacobian(jb)
            if ja:
                w[3:] = _cross(res.getNearestPoint1(), n)
                J[out_row] -= w @ joint_jacobian(ja)
        return J

    def _point_drift(self, state: State, joint: int, p: FloatArray) -> FloatArray:
        import pinocchio as pin

        model, data = self.robot.model, state.data
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        vel = pin.getVelocity(model, data, joint, frame)
        acc = pin.getClassicalAcceleration(model, data, joint, frame)
        r = p - data.oMi[joint].translation
        w = np.asarray(vel.angular)
        return np.asarray(acc.linear + np.cross(acc.angular, r) + np.cross(w, np.cross(w, r)))

    def drift(self, state: State) -> FloatArray:
        """Approximate drift (witness points rigidly attached, normal fixed)."""
        self._check_state(state)
        state._require_velocity("the collision drift")
        out = np.zeros(self.dim)
        for row, (res, (ja, jb)) in enumerate(zip(self._results(state), self._joints)):
            n = np.asarray(res.normal)
            if ja:
                out[row] -= n @ self._point_drift(state, ja, np.asarray(res.getNearestPoint1()))
            if jb:
                out[row] += n @ self._point_drift(state, jb, np.asarray(res.getNearestPoint2()))
        return out


class CollisionPenetration(Feature):
    """``phi(q) = 1/m sum_k [m - d_k]_+`` over collision pairs (slide 2:53).

    Jacobian ``-1/m sum_k [m - d_k > 0] J_d,k`` with ``J_d,k`` the rows of
    :class:`CollisionDistance`. Zero when every pair is farther apart than ``m``.

    Args:
        robot: the robot.
        margin: safety margin ``m`` [m].
        pairs: pairs to include (default all).
    """

    dim = 1

    def __init__(
        self, robot: Robot, margin: float = 0.05, pairs: Sequence[tuple[str, str]] | None = None
    ) -> None:
        super().__init__(robot, "collision_penetration")
        self.margin = check_positive(margin, "margin")
        self.distances = CollisionDistance(robot, pairs)

    def value(self, state: State) -> FloatArray:
        """Penetration (dimensionless), shape (1,)."""
        d = self.distances.value(state)
        return np.array([np.maximum(self.margin - d, 0.0).sum() / self.margin])

    def jacobian(self, state: State) -> FloatArray:
        """1 x nv Jacobian."""
        d = self.distances.value(state)
        active = (self.margin - d) > 0
        if not active.any():
            return np.zeros((1, self.robot.nv))
        J = self.distances.jacobian(state)
        return (-(active.astype(float) @ J) / self.margin)[None]

    def drift(self, state: State) -> FloatArray:
        """Approximate drift (see :class:`CollisionDistance`)."""
        d = self.distances.value(state)
        active = (self.margin - d) > 0
        return np.array([-(active.astype(float) @ self.distances.drift(state)) / self.margin])
