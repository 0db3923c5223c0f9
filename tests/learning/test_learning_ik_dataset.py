from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from taskspace.batch import BatchOptions, Executor
from taskspace.errors import InvalidInputError, ShapeError, UnknownNameError
from taskspace.learning.ik_dataset import IKDatasetOptions, ik_dataset, sample_reachable_poses
from taskspace.model import Robot


def test_ik_dataset_reaches_poses_same_on_every_backend(tmp_path: Path) -> None:
    robot = Robot.load("panda")
    poses = sample_reachable_poses(robot, 16, np.random.default_rng(4))
    serial = ik_dataset("panda", poses, batch=BatchOptions(backend="serial", progress=False))
    procs = ik_dataset(
        "panda",
        poses,
        batch=BatchOptions(backend="processes", workers=2, progress=False),
        results_file=tmp_path / "ik.jsonl",
    )
    assert np.array_equal(serial.q, procs.q) and np.array_equal(serial.success, procs.success)
    assert serial.success_rate >= 15 / 16
    # Independent check with Pinocchio alone: the configurations reach the poses.
    model = robot.model
    data = model.createData()
    fid = model.getFrameId(serial.frame)
    for pose, q, ok in zip(poses, serial.q, serial.success):
        if not ok:
            continue
        pin.framesForwardKinematics(model, data, q)
        reached = data.oMf[fid].homogeneous
        assert np.linalg.norm(reached[:3, 3] - pose[:3, 3]) < 1e-5
        assert np.linalg.norm(pin.log3(reached[:3, :3].T @ pose[:3, :3])) < 1e-4
        assert np.all(q >= model.lowerPositionLimit - 1e-9)
        assert np.all(q <= model.upperPositionLimit + 1e-9)
    out = serial.save(tmp_path / "ik.npz")
    loaded = np.load(out)
    assert np.array_equal(loaded["q"], serial.q)


def test_ik_dataset_bad_input() -> None:
    with pytest.raises(ShapeError):
        ik_dataset("panda", np.zeros((3, 3)))
    with pytest.raises(InvalidInputError):
        ik_dataset("panda", np.full((1, 4, 4), np.nan))
    with pytest.raises(UnknownNameError, match="valid frames are"):
        ik_dataset("panda", np.eye(4)[None], options=IKDatasetOptions(frame="hnd"))


def test_ik_dataset_reuses_a_given_executor() -> None:
    robot = Robot.load("panda")
    poses = sample_reachable_poses(robot, 6, np.random.default_rng(8))
    serial = ik_dataset("panda", poses, batch=BatchOptions(backend="serial", progress=False))
    with Executor(BatchOptions(backend="processes", workers=2, progress=False)) as ex:
        first = ik_dataset("panda", poses[:3], executor=ex)
        second = ik_dataset("panda", poses, executor=ex)
        assert ex._pool._pool is not None  # not closed by ik_dataset: still there to reuse
    assert np.array_equal(first.q, serial.q[:3])
    assert np.array_equal(second.q, serial.q) and np.array_equal(second.success, serial.success)
    # Independent check with Pinocchio: the successes reach their poses.
    data = robot.model.createData()
    fid = robot.model.getFrameId(serial.frame)
    for pose, q, ok in zip(poses, second.q, second.success):
        if ok:
            pin.framesForwardKinematics(robot.model, data, q)
            assert np.linalg.norm(data.oMf[fid].translation - pose[:3, 3]) < 1e-5
    with pytest.raises(InvalidInputError, match="not both"):
        ik_dataset("panda", poses, batch=BatchOptions(progress=False), executor=ex)
