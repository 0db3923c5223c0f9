"""Joint configuration itself ("homing", slide 2:55).

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
import pinocchio as pin

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError
from taskspace.features.compiled import CompiledTerm
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class JointConfiguration(Feature):
    """``phi(q) = q`` with Jacobian ``I``; on Lie-group joints the error is ``q (-) q*``.

    The target is a full configuration ``q*`` (size nq). The residual is Pinocchio's
    ``difference(q*, q)`` (size nv), exactly ``q - q*`` for revolute and prismatic joints;
    its Jacobian is ``dDifference``. With ``joints`` only those joints' rows are kept. On a
    floating-base robot the base's six rows are left out by default (a posture task then
    regulates the joints, not where the robot stands: what pink, mink and placo users expect);
    ``floating_base=True`` keeps them.

    Args:
        robot: the robot.
        joints: names of the joints to include (default: all, but the floating base unless
            ``floating_base``).
        floating_base: with ``joints=None`` on a floating-base robot, also regulate the base
            (its position and orientation rows).
    """

    def __init__(
        self, robot: Robot, joints: Sequence[str] | None = None, *, floating_base: bool = False
    ) -> None:
        super().__init__(robot, "joint_configuration")
        if not isinstance(floating_base, (bool, np.bool_)):
            raise InvalidInputError(
                f"floating_base must be True or False, got {type(floating_base).__name__}"
            )
        if joints is None and robot.is_floating and not floating_base:
            self.rows: np.ndarray | None = np.arange(6, robot.nv)
            self.dim = robot.nv - 6
        elif joints is None:
            self.rows = None
            self.dim = robot.nv
        else:
            if isinstance(joints, (str, bytes)) or not isinstance(joints, Sequence) or not joints:
                raise InvalidInputError(
                    f"joints must be a non-empty list of joint names, got {joints!r} (None: all)"
                )
            if not all(isinstance(name, str) for name in joints):
                raise InvalidInputError(f"joints must be joint names (strings), got {joints!r}")
            if len(set(joints)) != len(joints):
                raise InvalidInputError(f"joints has repeated names: {list(joints)}")
            rows: list[int] = []
            for name in joints:
                joint = robot._model.joints[robot.joint_id(name)]
                rows.extend(range(joint.idx_v, joint.idx_v + joint.nv))
            self.rows = np.asarray(rows, dtype=int)
            self.dim = len(rows)
        self._identity = np.eye(robot.nv) if self.rows is None else np.eye(robot.nv)[self.rows]
        # On vector-space configurations (no quaternions, no unit complexes) q (-) q* = q - q*.
        self._vector_space = robot.nq == robot.nv
        # The same holds row by row: Pinocchio's difference and dDifference are block-diagonal
        # by joint, and a joint with nq == nv (revolute, prismatic, translation...) is a vector
        # space, where they are q - q* and the identity. When every selected row belongs to
        # such a joint (a posture of a floating-base robot without its base rows), the
        # residual is q[iq] - q*[iq] (the same subtractions as Pinocchio's, bit-identical)
        # and the Jacobian the constant identity rows.
        self._q_rows: np.ndarray | slice | None = None
        if not self._vector_space and self.rows is not None:
            iq: list[int] = []
            for v_row in self.rows:
                joint = robot._model.joints[_joint_of_v_row(robot, int(v_row))]
                if joint.nq != joint.nv:
                    break
                iq.append(joint.idx_q + int(v_row) - joint.idx_v)
            else:
                q_rows = np.asarray(iq, dtype=int)
                contiguous = q_rows.size and np.all(np.diff(q_rows) == 1)
                self._q_rows = slice(int(q_rows[0]), int(q_rows[-1]) + 1) if contiguous else q_rows

    def compiled_term(self) -> CompiledTerm:
        """The kernel evaluates ``difference(q*, q)`` on all or the selected rows."""
        rows = None if self.rows is None else tuple(int(i) for i in self.rows)
        return CompiledTerm("posture", rows=rows)

    def check_target(self, target: Any) -> FloatArray:
        """Validate a target configuration (size nq)."""
        return self.robot.check_configuration(target, f"target of feature '{self.name}'")

    def value(self, state: State) -> FloatArray:
        """The configuration ``q`` (size nq)."""
        self._check_state(state)
        return state.q.copy()

    def jacobian(self, state: State) -> FloatArray:
        """Identity rows (dim x nv)."""
        self._check_state(state)
        return self._identity

    def drift(self, state: State) -> FloatArray:
        """Zero."""
        self._check_state(state)
        return np.zeros(self.dim)

    def residual(self, state: State, target: Any) -> FloatArray:
        """``difference(q*, q)`` restricted to the selected rows."""
        self._check_state(state)
        if self._q_rows is not None:
            return state.q[self._q_rows] - target[self._q_rows]
        diff = np.asarray(pin.difference(self.robot._model, target, state.q))
        return diff if self.rows is None else diff[self.rows]

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """Both the residual and its Jacobian."""
        if state.robot is self.robot:
            if self._vector_space:
                diff = state.q - target
                return (diff if self.rows is None else diff[self.rows]), self._identity
            q_rows = self._q_rows
            if q_rows is not None:  # every selected row on a vector-space joint
                return state.q[q_rows] - target[q_rows], self._identity
        return self.residual(state, target), self.residual_jacobian(state, target)

    def residual_jacobian(self, state: State, target: Any) -> FloatArray:
        """``dDifference(q*, q) / dq`` restricted to the selected rows."""
        self._check_state(state)
        if self._vector_space or self._q_rows is not None:
            return self._identity
        J = np.asarray(pin.dDifference(self.robot._model, target, state.q, pin.ARG1))
        return J if self.rows is None else J[self.rows]


def _joint_of_v_row(robot: Robot, v_row: int) -> int:
    """Index of the joint whose velocity block holds tangent row ``v_row``."""
    model = robot._model
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.idx_v <= v_row < joint.idx_v + joint.nv:
            return j
    raise InvalidInputError(f"tangent row {v_row} belongs to no joint")  # pragma: no cover
