"""``HierarchySolver.solve(hard_names=...)``: the names of the hard inequality blocks at fault.

The argument was documented "for diagnostics" but unused: a RELAXED cascade's ``culprits``
were empty (or named "hard inequalities" rows only in the vanished-row diagnosis) and a
relaxed level's QP named the hard rows "held inequalities". The references are the blocks'
violations computed here with numpy from the returned point, and the analytic least-violating
point of two contradictory rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.errors import InvalidInputError
from taskspace.ik import HierarchicalIK
from taskspace.qp.hierarchy import HierarchyLevel, HierarchySolver
from taskspace.qp.problem import RowBlock
from taskspace.qp.result import QPStatus
from taskspace.tasks import Task
from tests.conftest import load_robot
from tests.qp.problems_qp import vanished_hard_row


def _violations(x, C, l, u, blocks):  # type: ignore[no-untyped-def]
    Cx = C @ x
    v = np.maximum(l - Cx, Cx - u)
    return {b.name: float(v[b.start : b.stop].max(initial=0.0)) for b in blocks}


def test_conflicting_named_blocks_are_the_culprits() -> None:
    # x0 >= 1 ("push") against x0 <= 0 ("pull"); |x2| <= 1 ("z") holds
    C = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    l = np.array([1.0, -np.inf, -1.0])
    u = np.array([np.inf, 0.0, 1.0])
    names = [RowBlock("push", 0, 1), RowBlock("pull", 1, 2), RowBlock("z", 2, 3)]
    levels = [
        HierarchyLevel("a", np.array([[0.0, 1.0, 0.0]]), np.array([1.0])),
        HierarchyLevel("b", np.eye(3), np.zeros(3)),
    ]
    result = HierarchySolver().solve(levels, 3, C=C, l=l, u=u, hard_names=names)
    assert not result.success and result.status is QPStatus.RELAXED
    # the least-violating point splits the conflict: x0 = 1/2
    assert result.x[0] == pytest.approx(0.5, abs=1e-6)
    ref = _violations(result.x, C, l, u, names)
    violated = [name for name, v in ref.items() if v > 1e-6]
    assert violated == ["push", "pull"]
    assert result.culprits == violated
    # the relaxed level's QP names the blocks too (was "held inequalities")
    assert result.level_results[0].culprits == violated


def test_unnamed_rows_and_bounds() -> None:
    # rows 1..2 are not in a block: named "hard inequalities"; the box conflicts with row 0
    C = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 1.0]])
    l = np.array([2.0, 1.0, -np.inf])
    u = np.array([np.inf, np.inf, 0.0])
    lb, ub = np.full(2, -1.0), np.full(2, 1.0)
    levels = [HierarchyLevel("rest", np.eye(2), np.zeros(2))]
    result = HierarchySolver().solve(
        levels, 2, lb=lb, ub=ub, C=C, l=l, u=u, hard_names=[RowBlock("reach", 0, 1)]
    )
    assert not result.success
    ref = _violations(
        result.x, C, l, u, [RowBlock("reach", 0, 1), RowBlock("hard inequalities", 1, 3)]
    )
    expected = [name for name, v in ref.items() if v > 1e-6]
    if np.maximum(lb - result.x, result.x - ub).max() > 1e-6:
        expected.append("bounds")
    assert expected == ["reach", "hard inequalities", "bounds"]
    assert result.culprits == expected


def test_vanished_row_diagnosis_names_its_block() -> None:
    # A x = 1 fixes x0 + x1; the hard row "sum" (x0 + x1 = 3) cannot hold in any level
    data = vanished_hard_row()
    levels = data.pop("levels")
    names = [RowBlock("sum", 0, 1), RowBlock("height", 1, 2)]
    result = HierarchySolver().solve(levels, 3, hard_names=names, **data)
    assert result.status is QPStatus.RELAXED
    assert result.culprits[0] == "sum" and len(result.culprits) == 2
    assert "hard inequalities rows [0] (sum) vanish" in result.culprits[1]
    assert result.x[2] == pytest.approx(0.5, abs=1e-7)  # "height" holds, not named


def test_solved_cascade_has_no_culprits() -> None:
    C = np.array([[1.0, 0.0]])
    levels = [HierarchyLevel("a", np.eye(2), np.array([3.0, 0.0]))]
    result = HierarchySolver().solve(
        levels, 2, C=C, l=np.array([-1.0]), u=np.array([1.0]), hard_names=[RowBlock("c", 0, 1)]
    )
    assert result.success and result.culprits == []
    assert result.x[0] == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize(
    "hard_names",
    [
        [RowBlock("too far", 0, 3)],
        [RowBlock("backwards", 1, 0)],
        [("tuple", 0, 1)],
        RowBlock("not a list", 0, 1),
        "names",
    ],
)
def test_bad_hard_names_are_refused(hard_names: object) -> None:
    C = np.eye(2)
    levels = [HierarchyLevel("a", np.eye(2), np.zeros(2))]
    with pytest.raises(InvalidInputError, match="hard_names"):
        HierarchySolver().solve(
            levels,
            2,
            C=C,
            l=-np.ones(2),
            u=np.ones(2),
            hard_names=hard_names,  # type: ignore[arg-type]
        )


def test_hierarchical_ik_names_the_conflicting_constraints() -> None:
    # the end effector 0.5 m above and 0.5 m below its height: both rows at fault
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    s = robot.state(robot.q_default)
    pos = F.Position(robot, ee)
    p0 = pos.value(s)
    up = FeatureBounds(pos, [-np.inf, -np.inf, p0[2] + 0.5], np.inf, name="above")
    down = FeatureBounds(pos, -np.inf, [np.inf, np.inf, p0[2] - 0.5], name="below")
    wide = FeatureBounds(pos, p0 - 1.0, p0 + 1.0, name="wide")
    posture = F.JointConfiguration(robot)
    ik = HierarchicalIK(robot, [[Task(posture, robot.q_default)]], constraints=[up, down, wide])
    dt = 0.01
    result = ik.solve(s, dt)
    assert not result.success
    # reference: each constraint's linearized rows at the step
    ref = {}
    for c in (up, down, wide):
        Cc, lc, uc = c.inequalities(s, dt)
        Cx = np.asarray(Cc) @ result.dq
        ref[c.name] = float(np.maximum(np.asarray(lc) - Cx, Cx - np.asarray(uc)).max())
    violated = [name for name, v in ref.items() if v > 1e-6]
    assert violated == ["above", "below"]
    assert result.culprits == violated == result.hierarchy.culprits
