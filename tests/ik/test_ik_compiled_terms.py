"""Features declare whether the compiled IK kernel serves them (no type switches, #16).

A feature class the kernel serves returns a ``CompiledTerm`` from its own
``compiled_term``; a subclass that does not declare one (it may change the map) takes the
Python path; a new feature class that declares a term is served with no other code.
The kernel's steps are compared with quadprog's solution of the Python path's QP.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import quadprog

from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import (
    CenterOfMass,
    FramePose,
    JointConfiguration,
    Orientation,
    Position,
)
from taskspace.features.compiled import IK_KINDS, CompiledTerm, compiled_term
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.ik._native_stack import supported
from taskspace.model import Robot, State
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")


class ShiftedPosition(Position):
    """A subclass that changes the map: it must not be served by the kernel."""

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[np.ndarray, np.ndarray]:
        e, J = super().residual_and_jacobian(state, target)
        return e + 0.01, J


class Origin(Position):
    """A new feature class the kernel can evaluate: it declares its term, nothing else."""

    def compiled_term(self) -> CompiledTerm | None:
        return CompiledTerm("position", self.frame_id)


def test_declared_terms(panda: Robot) -> None:
    fid = panda.frame_id("panda_hand_tcp")
    assert compiled_term(Position(panda, "panda_hand_tcp")) == CompiledTerm("position", fid)
    assert compiled_term(FramePose(panda, "panda_hand_tcp")) == CompiledTerm("pose", fid)
    assert compiled_term(CenterOfMass(panda)) == CompiledTerm("com")
    assert compiled_term(JointConfiguration(panda)) == CompiledTerm("posture")
    assert compiled_term(Position(panda, "panda_hand_tcp", offset=[0, 0, 0.1])) is None
    # the hierarchical IK kernel does not evaluate orientations (IK_KINDS); the weighted
    # kernel does when it has add_orientation
    assert compiled_term(Orientation(panda, "panda_hand_tcp")) == CompiledTerm("orientation", fid)
    assert "orientation" not in IK_KINDS
    weighted = ik_kernel() is not None and hasattr(ik_kernel().WeightedIKKernel, "add_orientation")
    assert supported([Task(Orientation(panda, "panda_hand_tcp"), np.eye(3))]) is weighted
    assert compiled_term(ShiftedPosition(panda, "panda_hand_tcp")) is None  # not inherited
    assert compiled_term(Origin(panda, "panda_hand_tcp")) == CompiledTerm("position", fid)


def _quadprog_step(ik: DifferentialIK, state: State, dt: float) -> np.ndarray:
    p = ik.build(state, dt)
    n = p.n
    lo, hi = p.lb > -1e19, p.ub < 1e19
    C = np.hstack([np.eye(n)[lo].T, -np.eye(n)[hi].T])
    b = np.concatenate([p.lb[lo], -p.ub[hi]])
    return np.asarray(quadprog.solve_qp(p.H, -p.g, C, b, 0)[0])


@pytest.mark.parametrize("feature_class", [ShiftedPosition, Origin])
def test_kernel_serves_exactly_the_declared_features(feature_class: type) -> None:
    robot = load_robot("panda")
    rng = np.random.default_rng(0)
    state = robot.state(robot.q_default)
    task = Task(feature_class(robot, "panda_hand_tcp"))
    task.set_target(Position(robot, "panda_hand_tcp").value(state) + np.array([0.1, 0.05, -0.1]))
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot, [task, posture], [JointPositionLimits(robot), JointVelocityLimits(robot)]
    )
    declared = feature_class is Origin
    assert supported([task, posture]) is declared
    assert ik.native is declared
    for _ in range(3):
        state = robot.state(robot.q_default + 0.3 * rng.standard_normal(robot.nq))
        result = ik.solve(state, 0.02)
        assert (result.qp.backend == "native") is declared
        np.testing.assert_allclose(result.dq, _quadprog_step(ik, state, 0.02), atol=1e-8)
    python = DifferentialIK(
        robot, [task, posture], ik.constraints, options=DifferentialIKOptions(native=False)
    )
    np.testing.assert_allclose(python.solve(state, 0.02).dq, result.dq, atol=1e-7)
