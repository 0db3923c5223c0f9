"""solve_ik (Gauss-Newton with restarts, slides 2:29, 2:34) on random reachable Panda poses."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.features import FramePose, Position
from taskspace.ik import SolveIKOptions, SolveIKStatus, solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task

TCP = "panda_hand_tcp"


@pytest.mark.slow
def test_random_reachable_poses_success_rate(panda: Robot) -> None:
    rng = np.random.default_rng(2024)
    targets_rng = np.random.default_rng(7)
    task = Task(FramePose(panda, TCP))
    options = SolveIKOptions(restarts=10)  # the benchmark's setting
    successes = 0
    n = 200
    for _ in range(n):
        q_true = panda.random_configuration(targets_rng)
        target = panda.frame_placement(q_true, TCP)  # reachable by construction
        task.set_target(target)
        result = solve_ik(panda, [task], options=options, rng=rng)
        if not result.success:
            continue
        # independent check with Pinocchio forward kinematics
        reached = panda.frame_placement(result.q, TCP)
        position_error = np.linalg.norm(reached.translation - target.translation)
        rotation_error = np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))
        assert position_error <= 1e-6
        assert rotation_error <= 1e-5
        panda.check_limits(result.q, tolerance=1e-9)  # within the joint limits
        successes += 1
    assert successes >= 0.99 * n


def test_unreachable_target_fails_gracefully(panda: Robot) -> None:
    rng = np.random.default_rng(1)
    target = np.array([2.0, 0.0, 0.5])  # 2 m away: far beyond the ~0.9 m reach
    task = Task(Position(panda, TCP), target)
    t0 = time.perf_counter()
    result = solve_ik(panda, [task], options=SolveIKOptions(restarts=2), rng=rng)
    elapsed = time.perf_counter() - t0
    assert not result.success
    assert result.status in (SolveIKStatus.MAX_ITERATIONS, SolveIKStatus.STALLED)
    assert elapsed < 10.0
    assert result.attempts == 3
    error = result.errors[task.name]
    start_error = np.linalg.norm(panda.frame_placement(panda.q_default, TCP).translation - target)
    shoulder = np.array([0.0, 0.0, 0.333])
    reach = 0.316 + 0.384 + 0.0825 + 0.088 + 0.107 + 0.1034  # sum of Panda link offsets [m]
    assert np.isfinite(error)
    assert error < start_error  # it did get closer
    assert error >= np.linalg.norm(target - shoulder) - reach  # no better than physics allows
    # the error reported is the one of the returned configuration
    reached = panda.frame_placement(result.q, TCP).translation
    assert error == pytest.approx(np.linalg.norm(reached - target), rel=1e-9)
    panda.check_limits(result.q, tolerance=1e-9)


def test_solve_ik_converged_result_fields(panda: Robot) -> None:
    q_true = panda.q_default + 0.1
    target = panda.frame_placement(q_true, TCP)
    task = Task(FramePose(panda, TCP), target, gain=0.3)
    result = solve_ik(panda, [task])
    assert result.success and result.status is SolveIKStatus.CONVERGED
    assert result.attempts == 1
    assert result.iterations == len(result.cost_history) - 1
    assert np.all(np.diff(result.cost_history) < 0)  # accepted steps decrease the cost
    assert task.gain == 0.3  # restored


def test_restarts_without_rng_raises(panda: Robot) -> None:
    task = Task(Position(panda, TCP), [0.4, 0.0, 0.4])
    with pytest.raises(
        InvalidInputError,
        match=r"solve_ik with restarts needs rng=np\.random\.default_rng\(seed\)",
    ):
        solve_ik(panda, [task], options=SolveIKOptions(restarts=3))
