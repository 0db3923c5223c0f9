"""solve_ik keeps the attempt of least objective when no attempt converges.

Before (audit5): the kept attempt had the least unweighted sum of error norms, which mixes
metres and radians and counts directions of weight 0 (a frame pose asked for its position
only). Reference: every attempt replayed alone (restarts=0 from the same starts, drawn from
the same seeded stream) and its final cost f(q) = sum_i |sqrt(rho_i) e_i|^2 computed here.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace.features import FramePose
from taskspace.ik import SolveIKOptions, solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task


def _cost(robot: Robot, task: Task, q: np.ndarray) -> float:
    e = task.error(robot.state(q))
    return float(np.sum((np.asarray(task.sqrt_weight) * e) ** 2))


def test_kept_attempt_has_the_least_cost(panda: Robot) -> None:
    target = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0.0, 0.3), np.array([0.45, 0.25, 0.35]))
    task = Task(FramePose(panda, "panda_hand"), target, weight=[1, 1, 1, 0, 0, 0])
    opts = SolveIKOptions(max_iterations=2, restarts=4)  # no attempt converges in 2 steps
    result = solve_ik(panda, [task], options=opts, rng=np.random.default_rng(7))
    assert not result.success and result.attempts == 5
    rng = np.random.default_rng(7)
    starts = [panda.q_default] + [panda.random_configuration(rng) for _ in range(4)]
    single = SolveIKOptions(max_iterations=2)
    costs = [_cost(panda, task, solve_ik(panda, [task], s, options=single).q) for s in starts]
    assert _cost(panda, task, result.q) == min(costs)
    assert np.isclose(result.cost_history[-1], min(costs), rtol=1e-12)
