"""Gaps found by the issue #15 audit of stop 23 (robots outside the registry, odd inputs).

* Revolute joints whose description gives no range (URDF's default ``lower = upper = 0``:
  double_pendulum, quadruped's knees, centauro's wheels) are unbounded for the robot (its
  random configurations cover the circle), but ``ConfigurationSpace.from_robot`` refused them
  with "upper must be > lower in every coordinate; not at [0, 1]" (coordinates, no joint, no
  way out). It now names the joint and says what to do, as for infinite limits; with limits
  given through ``Robot.set_limits`` the robot plans, and the path is checked densely with
  Pinocchio's own ``computeCollisions`` (the reference).
* A failed rebuild of the kernels of an editable install (the ``CXX=/missing/g++`` case of the
  issue: the build raises inside the import machinery) falls back to the Python paths with the
  reason in ``taskspace._native.status()``; the IK step then matches Pinocchio's kinematics.
"""

from __future__ import annotations

import itertools
import subprocess
import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace import _native
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning import ConfigurationSpace, RRTConnectOptions, rrt_connect


def _load(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing effort limits: a documented warning
        return Robot.load(name)


@pytest.mark.parametrize(
    ("name", "joint", "base"),
    [
        ("double_pendulum", "joint1", {}),
        ("quadruped", "BL_KFE", {"base_lower": [-1, -1, 0], "base_upper": [1, 1, 1]}),
    ],
)
def test_joint_without_range_is_named_when_planning(
    name: str, joint: str, base: dict[str, list[float]]
) -> None:
    robot = _load(name)
    jid = robot.model.getJointId(joint)
    iq = robot.model.joints[jid].idx_q
    assert robot.model.lowerPositionLimit[iq] == robot.model.upperPositionLimit[iq] == 0.0
    # the robot itself treats it as unbounded: its samples cover the circle
    rng = np.random.default_rng(0)
    samples = np.array([robot.random_configuration(rng)[iq] for _ in range(200)])
    assert samples.min() < -2.5 and samples.max() > 2.5
    with pytest.raises(InvalidInputError, match=rf"joint '{joint}' has no position range") as info:
        ConfigurationSpace.from_robot(robot, **base)  # type: ignore[arg-type]
    assert "Robot.set_limits" in str(info.value) and "locked_joints" in str(info.value)


def test_joint_without_range_plans_once_given_limits() -> None:
    robot = _load("double_pendulum")
    lower, upper = robot.lower_limits.copy(), robot.upper_limits.copy()
    lower[:], upper[:] = -np.pi, np.pi
    robot.set_limits(lower=lower, upper=upper)
    space = ConfigurationSpace.from_robot(robot)
    q0, q1 = np.array([-2.5, 0.3]), np.array([2.5, -0.4])
    result = rrt_connect(space, q0, q1, RRTConnectOptions(seed=1, time_limit_s=10.0))
    assert result.success, result.status
    path = np.asarray(result.path)
    np.testing.assert_array_equal(path[0], q0)
    np.testing.assert_array_equal(path[-1], q1)
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    for a, b in itertools.pairwise(path):
        assert np.all(a >= lower - 1e-12) and np.all(a <= upper + 1e-12)
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.01)))
        for s in np.linspace(0.0, 1.0, n + 1):
            assert not pin.computeCollisions(model, data, geom, gdata, a + s * (b - a), True)


@pytest.fixture
def fresh_loader():  # type: ignore[no-untyped-def]
    _native._load_module.cache_clear()
    yield
    _native._load_module.cache_clear()


def test_failed_editable_rebuild_falls_back_to_python(
    monkeypatch: pytest.MonkeyPatch,
    fresh_loader: None,
    caplog: pytest.LogCaptureFixture,
) -> None:
    from taskspace.features import Position
    from taskspace.ik import DifferentialIK
    from taskspace.tasks import Task

    def failed_build(name: str, *args: object) -> None:
        if name.startswith("taskspace._native._"):
            # what scikit-build-core's redirecting finder raises when the rebuild fails
            raise subprocess.CalledProcessError(1, ["cmake", "--build"], "CXX=/missing/g++")
        return None

    monkeypatch.setattr(_native.importlib.util, "find_spec", failed_build)
    with caplog.at_level("WARNING", logger="taskspace._native"):
        assert _native.ik_kernel() is None
        assert _native.planning_kernel() is None
    assert "could not be rebuilt" in _native.status()
    assert any("Python path instead" in r.getMessage() for r in caplog.records)
    assert _native.build_info() == {}
    monkeypatch.undo()  # imports work again; the loader's answer stays cached
    assert _native.ik_kernel() is None  # so the IK below runs its Python path

    robot = _load("ur5")
    start = robot.frame_placement(robot.q_default, "tool0").translation
    target = start + np.array([0.03, -0.02, 0.04])
    ik = DifferentialIK(robot, [Task(Position(robot, "tool0"), target)])
    state = robot.state(robot.q_default)
    for _ in range(200):
        ik.advance(state, 0.05)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, state.q)
    reached = data.oMf[robot.model.getFrameId("tool0")].translation
    np.testing.assert_allclose(reached, target, atol=1e-4)


def test_space_is_valid_refuses_what_it_used_to_truncate() -> None:
    """``ConfigurationSpace.is_valid`` dropped imaginary parts, parsed text, and raised a bare
    ``IndexError`` on ``None`` or a scalar; answers on real vectors are Pinocchio's."""
    robot = _load("bravo7_no_ee")  # with a continuous (RUBZ) joint
    space = ConfigurationSpace.from_robot(robot)
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    rng = np.random.default_rng(3)
    answers = set()
    for _ in range(40):
        q = robot.random_configuration(rng)
        free = not pin.computeCollisions(model, data, geom, gdata, q, True)
        answers.add(free)
        assert space.is_valid(q) is free
        assert space.is_valid(list(q)) is free  # a list is converted, not refused
    assert answers == {True, False}  # both answers were checked
    q = robot.q_default
    assert space.is_valid(np.r_[q[:-1], np.nan]) is False
    for bad, match in [
        (q + 1j, "complex"),
        (q.astype(str), "text"),
        (None, "None"),
    ]:
        with pytest.raises(InvalidInputError, match=match):
            space.is_valid(bad)  # type: ignore[arg-type]
    for bad in (0.5, q[:-1], q[None, :]):
        with pytest.raises(InvalidInputError, match=r"shape|q"):
            space.is_valid(bad)  # type: ignore[arg-type]
