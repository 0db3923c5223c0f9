"""Culprits of a RELAXED InverseDynamicsQP result: the blocks the returned point violates.

simple_humanoid on flat feet with its ankles 0.25-0.42 rad outside their range: the joint-limit
acceleration bounds conflict with the contacts. The hierarchical controller's RELAXED result
had an empty culprit list; the weighted one names the blocks its least-violating point
violates (all six here: the quadratic penalty spreads the violation over every block).
The reference is the violation of each block computed here from ``build(state)``'s arrays.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace import features as F
from taskspace.control.inverse_dynamics_qp import (
    InverseDynamicsOptions,
    InverseDynamicsQP,
    InverseDynamicsStatus,
)
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.control.test_control_no_hang import flat_footed_humanoid


def _humanoid(hierarchical: bool):  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("simple_humanoid", geometry=False)
    return flat_footed_humanoid(robot, InverseDynamicsOptions(hierarchical=hierarchical))


def _block_violations(ctrl, s, x):  # type: ignore[no-untyped-def]
    """Largest violation of each named block, from the arrays of build(s) (numpy only)."""
    p = ctrl.build(s)
    out = {}
    for blk in p.eq_blocks:
        r = slice(blk.start, blk.stop)
        out[blk.name] = float(np.max(np.abs(p.A[r] @ x - p.b[r]), initial=0.0))
    for blk in p.in_blocks:
        r = slice(blk.start, blk.stop)
        Cx = p.C[r] @ x
        out[blk.name] = float(np.max(np.maximum(p.l[r] - Cx, Cx - p.u[r]), initial=0.0))
    for blk in p.box_blocks:
        r = slice(blk.start, blk.stop)
        v = np.maximum(p.lb[r] - x[r], x[r] - p.ub[r])
        out[blk.name] = float(np.max(v, initial=0.0))
    return out


@pytest.mark.parametrize("hierarchical", [False, True])
def test_relaxed_culprits_are_the_violated_blocks(hierarchical: bool) -> None:
    ctrl, s, contacts = _humanoid(hierarchical)
    res = ctrl.solve(s)
    assert res.status is InverseDynamicsStatus.RELAXED and not res.success
    x = np.concatenate([res.a, *[res.forces[c.frame] for c in contacts]])
    ref = _block_violations(ctrl, s, x)
    violated = [name for name, v in ref.items() if v > 1e-6]
    assert "joint limits" in violated  # the ankles' bounds are the conflict's one side
    assert [c for c in res.culprits if c in ref] == violated
    # no block the point satisfies is named
    assert all(ref[c] > 1e-6 for c in res.culprits if c in ref)
    if hierarchical:
        # the cascade holds the hard equalities exactly: only inequality blocks are named
        assert set(violated) <= {"friction cones", "torque limits", "joint limits"}


def test_solved_hierarchical_result_has_no_culprits() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("panda", geometry=False)
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    posture = Task(F.JointConfiguration(robot), robot.q_default, kp=10.0)
    ctrl = InverseDynamicsQP(robot, [posture], options=InverseDynamicsOptions(hierarchical=True))
    res = ctrl.solve(s)
    assert res.success and res.culprits == []
