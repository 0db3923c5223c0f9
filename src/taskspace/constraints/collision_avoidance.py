"""Collision avoidance as velocity dampers on coal distances.

Thread safety: a constraint keeps no per-step workspace besides immutable caches replaced at
once (e.g. the velocity box for the last ``dt``), and reads the :class:`~taskspace.model.State`
it is given, so one constraint may serve solvers in several threads. What it derives from the
robot (limits, collision pairs, compiled rows) is rebuilt on the next call after a model or
world change; do not change the robot, the world or the constraint's parameters (bounds, gains,
margins) while another thread steps with it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from taskspace._validation import check_positive
from taskspace.constraints.constraint import Constraint
from taskspace.errors import InvalidInputError
from taskspace.features.collision import CollisionDistance
from taskspace.features.compiled import CompiledConstraint
from taskspace.features.rows import INF, InequalityRows

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class CollisionAvoidance(Constraint):
    """Velocity damper ``J_d dq >= -gain (d - d_s)`` for every pair closer than ``d_i``.

    With the linearization ``d(q + dq) ~ d + J_d dq`` and ``gain = 1`` the next distance is at
    least the safety distance ``d_s``; smaller gains approach obstacles more gently (the
    classical damper ``d' >= -xi (d - d_s) / (d_i - d_s)`` in step form). Pairs farther than
    the influence distance ``d_i`` add no row. Use convex collision geometry
    (``Robot.load(..., convex_collision=True)``): mesh distances cost milliseconds.

    Args:
        robot: the robot.
        safety_distance: ``d_s`` [m].
        influence_distance: ``d_i`` [m].
        gain: in (0, 1].
        pairs: pairs to consider (default every collision pair, self and world).
    """

    def __init__(
        self,
        robot: Robot,
        safety_distance: float = 0.01,
        influence_distance: float = 0.1,
        gain: float = 0.5,
        pairs: Sequence[tuple[str, str]] | None = None,
    ) -> None:
        super().__init__(robot, "collision avoidance")
        self.safety_distance = safety_distance  # checked by __setattr__
        self.influence_distance = influence_distance
        self.gain = gain
        self.distances = CollisionDistance(robot, pairs)
        self._compiled: tuple[tuple[int, float, float, float], CompiledConstraint] | None = None

    def __setattr__(self, name: str, value: object) -> None:
        """Check ``safety_distance``, ``influence_distance`` and ``gain`` on every assignment.

        They may change between steps (both paths read them at every step); a bad value raises
        :class:`~taskspace.errors.InvalidInputError` and leaves the constraint unchanged.
        """
        if name in ("safety_distance", "influence_distance", "gain"):
            value = check_positive(value, name, strict=name != "safety_distance")
            if name == "gain" and value > 1.0:
                raise InvalidInputError(f"gain must be in (0, 1], got {value}")
            safety = value if name == "safety_distance" else getattr(self, "safety_distance", 0.0)
            influence = (
                value if name == "influence_distance" else getattr(self, "influence_distance", INF)
            )
            if influence <= safety:
                raise InvalidInputError("influence_distance must be larger than safety_distance")
        super().__setattr__(name, value)

    def inequalities(self, state: State, dt: float) -> InequalityRows:
        """Rows for the pairs within the influence distance (possibly zero rows)."""
        d = self.distances.value(state)
        near = d < self.influence_distance
        nv = self.robot.nv
        if not near.any():
            return InequalityRows(np.zeros((0, nv)), np.zeros(0), np.zeros(0))
        J = self.distances.jacobian(state, rows=near)
        lower = -self.gain * (d[near] - self.safety_distance)
        return InequalityRows(J, lower, np.full(J.shape[0], INF))

    def compiled_constraint(self) -> CompiledConstraint:
        """The dampers as the compiled IK kernel evaluates them (the same rows).

        The same object while the obstacle world and the parameters are unchanged (the
        compiled path asks at every step and compares by identity).
        """
        distances = self.distances
        key = (
            self.robot.world.version,
            self.safety_distance,
            self.influence_distance,
            self.gain,
        )
        cached = self._compiled
        if cached is not None and cached[0] == key:
            return cached[1]
        if key[0] != distances._world_version:
            distances._follow_world()  # pair indices shift when obstacles change
        rows = CompiledConstraint("dampers", tuple(distances._pairs), *key[1:])
        self._compiled = (key, rows)
        return rows

    def active_pairs(self, state: State) -> list[tuple[str, str, float]]:
        """Pairs within the influence distance with their distances [m]."""
        d = self.distances.value(state)
        return [
            (a, b, float(dist))
            for (a, b), dist in zip(self.distances.pair_names, d)
            if dist < self.influence_distance
        ]
