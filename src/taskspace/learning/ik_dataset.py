"""Inverse-kinematics datasets for learning: poses in, configurations and success out.

Each pose is one task of a :mod:`taskspace.batch` run: :func:`taskspace.ik.solve_ik` from the
robot's default posture, then from random restarts drawn from the task's own generator. The
robot is loaded once per worker by name, so the same call runs serially, on local processes
or on a Ray cluster, with the same configurations.

Thread safety: :func:`ik_dataset` and :func:`sample_reachable_poses` build their robots,
solvers and generators per call (or per worker of :mod:`taskspace.batch`) and may run from
several threads; the options are immutable and an :class:`IKDataset` is plain result data.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace import features as F
from taskspace._validation import as_float_array
from taskspace.batch import BatchOptions, BatchResult, Executor
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.ik import SolveIKOptions, solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class IKDatasetOptions:
    """Settings of :func:`ik_dataset`.

    Attributes:
        frame: the frame whose pose is asked for (None: the robot's first end effector).
        restarts: random restarts of :func:`solve_ik` after the attempt from the default
            posture.
        position_tolerance: success threshold on the position error [m].
        rotation_tolerance: success threshold on the rotation error [rad].
    """

    frame: str | None = None
    restarts: int = 3
    position_tolerance: float = 1e-6
    rotation_tolerance: float = 1e-5


@dataclass(frozen=True)
class IKDataset:
    """Poses and their IK solutions.

    Attributes:
        robot: the robot's name.
        frame: the frame the poses are of.
        poses: homogeneous transforms of the frame in the world, shape ``(N, 4, 4)``.
        q: the configurations found (the best attempt when unsuccessful), ``(N, nq)``.
        success: whether each pose was reached within the tolerances, ``(N,)``.
        position_error: final position error [m], ``(N,)``.
        batch: the batch run (backend, workers, timings, failed tasks).
    """

    robot: str
    frame: str
    poses: FloatArray
    q: FloatArray
    success: npt.NDArray[np.bool_]
    position_error: FloatArray
    batch: BatchResult

    @property
    def success_rate(self) -> float:
        """Fraction of the poses that were reached."""
        return float(np.mean(self.success)) if len(self.success) else 0.0

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the arrays to a compressed ``.npz`` file and return its path."""
        out = Path(path)
        np.savez_compressed(
            out,
            poses=self.poses,
            q=self.q,
            success=self.success,
            position_error=self.position_error,
            robot=self.robot,
            frame=self.frame,
        )
        return out


def _solve_pose(item: Any, rng: np.random.Generator, context: Any) -> list[Any]:
    """Task: solve IK for one pose; returns ``[success, position_error, *q]``."""
    robot, frame, options = context
    target = pin.SE3(np.asarray(item, dtype=np.float64))
    task = Task(F.FramePose(robot, frame))
    task.set_target(target)
    opts = SolveIKOptions(
        restarts=options.restarts,
        position_tolerance=options.position_tolerance,
        rotation_tolerance=options.rotation_tolerance,
    )
    result = solve_ik(robot, [task], options=opts, rng=rng)
    error = float(np.linalg.norm(task.error(robot.state(result.q))[:3]))
    return [bool(result.success), error, *np.asarray(result.q, dtype=float).tolist()]


def _context(robot_name: str, frame: str | None, options: IKDatasetOptions) -> Any:
    robot = Robot.load(robot_name)
    return robot, _frame(robot, frame), options


def _frame(robot: Robot, frame: str | None) -> str:
    if frame is not None:
        robot.frame_id(frame)  # raises UnknownNameError listing the frames
        return frame
    if not robot.end_effectors:
        raise InvalidInputError(f"robot {robot.name!r} names no end effector: pass frame=...")
    return robot.end_effectors[0]


def sample_reachable_poses(
    robot: Robot, n: int, rng: np.random.Generator, frame: str | None = None
) -> FloatArray:
    """Poses of ``frame`` at ``n`` uniform random configurations, shape ``(n, 4, 4)``."""
    if not isinstance(n, (int, np.integer)) or n < 0:
        raise InvalidInputError(f"n must be an integer >= 0, got {n!r}")
    fid = robot.frame_id(_frame(robot, frame))
    poses = np.empty((int(n), 4, 4))
    for i in range(int(n)):
        poses[i] = robot.state(robot.random_configuration(rng)).frame_placement(fid).homogeneous
    return poses


def ik_dataset(
    robot: str,
    poses: Any,
    *,
    options: IKDatasetOptions | None = None,
    batch: BatchOptions | None = None,
    executor: Executor | None = None,
    results_file: str | os.PathLike[str] | None = None,
) -> IKDataset:
    """Solve IK for every pose, in parallel through :class:`taskspace.batch.Executor`.

    Args:
        robot: the robot's name (as for ``Robot.load``; each worker loads it once).
        poses: homogeneous transforms ``(N, 4, 4)`` of the frame in the world [m].
        options: IK settings.
        batch: the settings (backend, workers, seed) of an executor made for this call and
            closed after it.
        executor: an executor to use instead (not closed): its worker processes or actors,
            started and holding the robot after a first call, serve the next ones at once.
        results_file: a JSON Lines file that makes an interrupted run resumable.

    Returns:
        The dataset; ``success`` says which poses were reached.

    Raises:
        InvalidInputError: if both ``batch`` and ``executor`` are given.
    """
    if batch is not None and executor is not None:
        raise InvalidInputError(
            "pass batch (the options of a new executor) or executor (one to reuse), not both"
        )
    opts = options or IKDatasetOptions()
    arr = as_float_array(poses, "poses")
    if arr.ndim != 3 or arr.shape[1:] != (4, 4):
        raise ShapeError("poses", (len(arr) if arr.ndim else 0, 4, 4), arr.shape)
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError("poses must be finite")
    loaded = Robot.load(robot)
    frame = _frame(loaded, opts.frame)
    items = [p.tolist() for p in arr]
    owned = executor is None
    runner = Executor(batch) if executor is None else executor
    try:
        result = runner.map(
            _solve_pose,
            items,
            context=functools.partial(_context, robot, frame, opts),
            results_file=results_file,
            description=f"IK {robot}",
        )
    finally:
        if owned:
            runner.close()
    nq = loaded.nq
    q = np.full((len(items), nq), np.nan)
    success = np.zeros(len(items), dtype=bool)
    error = np.full(len(items), np.nan)
    for r in result.records:
        if r.ok:
            success[r.index], error[r.index] = bool(r.value[0]), float(r.value[1])
            q[r.index] = r.value[2:]
    return IKDataset(robot, frame, arr, q, success, error, result)
