"""The compiled path of :class:`~taskspace.ik.DifferentialIK` (``taskspace/_native/ik_kernel.cpp``).

It evaluates the same QP as :meth:`DifferentialIK.build` (task rows from the state's
Pinocchio data, ``H = M^T M + mu I``, boxes combined by the rules of ``combine_bounds``) and
solves it exactly with a primal active-set method on the box. It serves stacks made of frame
poses, frame positions, the center of mass and posture tasks, with box constraints only
(joint position, velocity and acceleration limits); anything else takes the Python path.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from taskspace._native import ik_kernel
from taskspace.constraints.constraint import Constraint
from taskspace.constraints.joint_limits import JointPositionLimits
from taskspace.errors import InvalidInputError
from taskspace.features.center_of_mass import CenterOfMass
from taskspace.features.frame_pose import FramePose
from taskspace.features.joint_configuration import JointConfiguration
from taskspace.features.position import Position
from taskspace.model.robot import Robot
from taskspace.model.state import State
from taskspace.tasks import Task

MAX_ACTIVE_SET_ITERATIONS = 200


def supported(tasks: Sequence[Task]) -> bool:
    """Whether the compiled kernel can run these tasks (with box constraints only)."""
    if ik_kernel() is None or not tasks:
        return False
    for t in tasks:
        f: Any = t.feature
        kind = type(f)
        if kind is Position:
            if f.offset is not None:
                return False
        elif kind not in (FramePose, CenterOfMass, JointConfiguration):
            return False
    return True


class NativeWeightedStack:
    """Owns one compiled kernel for a fixed list of tasks and box constraints.

    The kernel is built for ``robot.model`` and only ever receives that model and the
    ``pin.Data`` of a :class:`~taskspace.model.State` made from it (a state's data cannot be
    replaced); a state of another model is refused before the kernel is called.

    Thread safety: not thread-safe (the kernel holds the QP workspace);
    :class:`~taskspace.ik.DifferentialIK` serializes its calls with its lock.
    """

    def __init__(self, robot: Robot, tasks: Sequence[Task], constraints: Sequence[Constraint]):
        module = ik_kernel()
        assert module is not None
        self.module = module
        model = robot.model
        self.robot = robot
        self.model = model
        kernel = module.WeightedIKKernel(robot.nv, robot.nq)
        rows = [t for t in tasks if type(t.feature) is not JointConfiguration]
        posture = [t for t in tasks if type(t.feature) is JointConfiguration]
        for t in rows:
            f: Any = t.feature
            if type(f) is FramePose:
                kernel.add_pose(model, f.frame_id)
            elif type(f) is Position:
                kernel.add_position(model, f.frame_id)
            else:
                kernel.add_com()
        for t in posture:
            sel = t.feature.rows  # type: ignore[attr-defined]
            kernel.add_posture(None if sel is None else [int(i) for i in sel])
        self.kernel = kernel
        self.tasks = rows + posture
        self._n_rows = sum(t.dim for t in rows)
        self._posture = posture
        self._keys: list[tuple[Any, float]] = []
        boxes = [c for c in constraints if _has_bounds(c)]
        # the first joint-position box is evaluated by the kernel from q (the others here)
        position = next((c for c in boxes if type(c) is JointPositionLimits), None)
        if position is not None:
            kernel.set_position_limits(*position.kernel_arguments())
            boxes.remove(position)
        self._hard = [c for c in boxes if c.hard_bounds]
        self._soft = [c for c in boxes if not c.hard_bounds]
        self.nv = robot.nv

    def _scale(self) -> None:
        if self._keys:
            for t, (w, g) in zip(self.tasks, self._keys):
                if t.sqrt_weight is not w or t.gain is not g:
                    break
            else:
                return
        keys = [(t.sqrt_weight, t.gain) for t in self.tasks]
        nv = self.nv
        w = np.zeros(self._n_rows + nv * len(self._posture))
        c = np.zeros_like(w)
        k = 0
        for t in self.tasks:
            f: Any = t.feature
            if type(f) is JointConfiguration and f.rows is not None:
                sel = k + f.rows
                w[sel] = t.sqrt_weight
                c[sel] = -t.gain * np.asarray(t.sqrt_weight)
                k += nv
                continue
            d = nv if type(t.feature) is JointConfiguration else t.dim
            w[k : k + d] = t.sqrt_weight
            c[k : k + d] = -t.gain * np.asarray(t.sqrt_weight)
            k += d
        self.kernel.set_scaling(w, c)
        self._keys = keys

    def solve(
        self, state: State, dt: float, damping: float, out: np.ndarray
    ) -> tuple[int, int, float, float, float] | None:
        """``(status, iterations, objective, build_time, qp_time)``; the step is written to ``out``.

        ``None`` when the active set did not settle (the caller takes the Python path).
        """
        model = self.model
        if state._model is not model:  # the kernel must never see a Data of another model
            raise InvalidInputError(
                f"this IK solver is built for robot '{self.robot.name}'; the state belongs to "
                f"robot '{state.robot.name}': make the state with this robot's state(q)"
            )
        self._scale()
        targets = [t._target for t in self.tasks]
        try:
            status, iterations, objective, t_build, t_qp, _ = self.kernel.solve(
                model,
                state._data,  # made by the state for ``state._model``, cannot be replaced
                state.q,
                targets,
                [b for c in self._hard if (b := c.bounds(state, dt)) is not None],
                [b for c in self._soft if (b := c.bounds(state, dt)) is not None],
                damping,
                out,
                MAX_ACTIVE_SET_ITERATIONS,
            )
        except (TypeError, ValueError, RuntimeError):
            for t in self.tasks:
                t._require_target()  # a task without a target: raises, naming it
            raise
        if status == self.module.MAX_ITERATIONS:
            return None
        return status, iterations, objective, t_build, t_qp


def _has_bounds(c: Constraint) -> bool:
    return type(c).bounds is not Constraint.bounds
