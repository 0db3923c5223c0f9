"""Collision distances and the penetration of collision limits (slide 2:53), from coal.

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


_ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


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

    Raises:
        InvalidInputError: a robot without collision geometry, or malformed ``pairs``.
        UnknownNameError: a pair that is not a collision pair of the robot.
    """

    def __init__(self, robot: Robot, pairs: Sequence[tuple[str, str]] | None = None) -> None:
        super().__init__(robot, "collision_distance")
        if robot.robot_geometry_count == 0:
            raise InvalidInputError(
                f"robot {robot.name!r} has no collision geometry (loaded with geometry=False, "
                "or its URDF has no collision elements): collision distances would have no "
                "pair to measure, and a collision-avoidance constraint would add no row"
            )
        all_pairs = robot.collision_pairs
        if pairs is None:
            self.pair_indices = np.arange(len(all_pairs))
        else:
            if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Sequence) or not pairs:
                raise InvalidInputError(
                    "pairs must be a non-empty list of (geometry name, geometry name) pairs "
                    f"(robot.collision_pairs lists them), got {pairs!r}"
                )
            for pair in pairs:
                if (
                    isinstance(pair, (str, bytes))
                    or not isinstance(pair, Sequence)
                    or len(pair) != 2
                    or not all(isinstance(g, str) for g in pair)
                ):
                    raise InvalidInputError(
                        f"each collision pair must be two geometry names, got {pair!r}"
                    )
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
        objs = robot._collision_model.geometryObjects
        cps = robot._collision_model.collisionPairs
        self._joints = [
            (int(objs[cps[int(k)].first].parentJoint), int(objs[cps[int(k)].second].parentJoint))
            for k in self.pair_indices
        ]
        self.pair_names = [all_pairs[k] for k in self.pair_indices]
        self._pairs = [int(k) for k in self.pair_indices]
        self._every_pair = pairs is None
        self._world_version = robot.world.version
        # joint Jacobian of joint j in WORLD coordinates = data.J with the columns outside
        # the support of j zeroed: one mask row per pair and side (universe: all zero)
        model = robot._model
        support = np.zeros((model.njoints, robot.nv))
        for j in range(1, model.njoints):
            for s in model.supports[j]:
                if s:
                    joint = model.joints[s]
                    support[j, joint.idx_v : joint.idx_v + joint.nv] = 1.0
        self._mask_a = support[[ja for ja, _ in self._joints]].reshape(self.dim, robot.nv)
        self._mask_b = support[[jb for _, jb in self._joints]].reshape(self.dim, robot.nv)
        self._moving_a_list = [ja != 0 for ja, _ in self._joints]
        self._moving_b_list = [jb != 0 for _, jb in self._joints]
        self._any_moving_a = any(self._moving_a_list)

    def _follow_world(self) -> None:
        """Re-index the pairs after the obstacle world changed (pair indices shift).

        Raises:
            InvalidInputError: a pair of this feature no longer exists, or (for a feature of
                every pair) the set of pairs changed: build the feature again.
        """
        robot = self.robot
        names = robot.collision_pairs
        if self._every_pair and names != self.pair_names:
            raise InvalidInputError(
                "the obstacle world changed since this CollisionDistance (every pair) was "
                f"built: it had {len(self.pair_names)} pairs, the robot now checks "
                f"{len(names)}; build the feature (and its task or constraint) again"
            )
        lookup = {p: k for k, p in enumerate(names)}
        missing = [p for p in self.pair_names if p not in lookup]
        if missing:
            raise InvalidInputError(
                f"collision pairs {missing} of this feature no longer exist after the obstacle "
                "world changed; build the feature again with pairs from robot.collision_pairs"
            )
        self._pairs = [lookup[p] for p in self.pair_names]
        self.pair_indices = np.asarray(self._pairs, dtype=int)
        self._world_version = robot.world.version

    def _results(self, state: State) -> list[Any]:
        if self.robot._world._version != self._world_version:
            self._follow_world()
        results = state.distance_results()
        return [results[k] for k in self._pairs]

    def value(self, state: State) -> FloatArray:
        """Signed distances [m]."""
        self._check_state(state)
        return np.array([r.min_distance for r in self._results(state)])

    def jacobian(self, state: State, rows: npt.NDArray[Any] | None = None) -> FloatArray:
        """Dim x nv Jacobian (only the ``rows`` selected by index or mask, if given).

        Row k is ``[n; p_b x n]^T J_b - [n; p_a x n]^T J_a`` with ``J`` the WORLD joint
        Jacobians (the velocity of a point ``p`` is ``v_O + omega x p`` and
        ``n . (omega x p) = omega . (p x n)``). ``J_a``, ``J_b`` are the columns of
        Pinocchio's ``data.J`` (computed by the state's update) in the support of the
        geometries' parent joints.
        """
        self._check_state(state)
        results = self._results(state)
        if rows is None:
            selected: npt.NDArray[np.intp] = np.arange(self.dim)
        else:
            selected = np.arange(self.dim)[rows]
        m = len(selected)
        nv = self.robot.nv
        if m == 0:
            return np.zeros((0, nv))
        zero = _ZERO6
        moving_a, moving_b = self._moving_a_list, self._moving_b_list
        w_a: list[Sequence[float]] = []
        w_b: list[Sequence[float]] = []
        for k in selected.tolist():
            res = results[k]
            n0, n1, n2 = res.normal.tolist()
            # [n; p x n] for each moving side (scalar arithmetic: numpy is slower for 3-vectors)
            if moving_b[k]:
                p0, p1, p2 = res.getNearestPoint2().tolist()
                w_b.append((n0, n1, n2, p1 * n2 - p2 * n1, p2 * n0 - p0 * n2, p0 * n1 - p1 * n0))
            else:
                w_b.append(zero)
            if moving_a[k]:
                p0, p1, p2 = res.getNearestPoint1().tolist()
                w_a.append((n0, n1, n2, p1 * n2 - p2 * n1, p2 * n0 - p0 * n2, p0 * n1 - p1 * n0))
            else:
                w_a.append(zero)
        J0 = state.data.J  # 6 x nv, WORLD: column i is the motion of joint dof i
        J = np.array(w_b).dot(J0)
        J *= self._mask_b[selected]
        if self._any_moving_a:
            J -= np.array(w_a).dot(J0) * self._mask_a[selected]
        return J

    def _point_drift(self, state: State, joint: int, p: FloatArray) -> FloatArray:
        import pinocchio as pin

        model, data = self.robot._model, state.data
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
