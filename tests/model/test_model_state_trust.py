"""A State's kinematics always belong to its q, v and model (issue #15, stale state, swapped data).

References: Pinocchio's own ``framesForwardKinematics`` / ``computeFrameJacobian`` on fresh
data. Calls that used to crash the interpreter run in a subprocess.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.model import Robot


@pytest.fixture(scope="module")
def planar() -> Robot:
    return Robot.load("planar_2link")


def _q(robot: Robot, seed: int = 0) -> np.ndarray:
    return robot.random_configuration(np.random.default_rng(seed))


def test_q_and_v_cannot_be_made_writable_again(panda: Robot) -> None:
    v = np.linspace(-0.5, 0.5, panda.nv)
    with_v = panda.state(_q(panda), v)
    without_v = panda.state(_q(panda))
    for arr in (with_v.q, with_v.v, without_v.q, without_v.v):
        with pytest.raises(ValueError):
            arr[0] = 1.0
        with pytest.raises(ValueError):
            arr.setflags(write=True)  # would let q drift away from the kinematics


def test_kinematics_follow_q_not_the_callers_array(panda: Robot) -> None:
    q = _q(panda, 1)
    state = panda.state(q)
    q_before = q.copy()
    q[:] = _q(panda, 2)  # the caller reuses its buffer
    np.testing.assert_array_equal(state.q, q_before)
    data = panda.model.createData()
    fid = panda.frame_id("panda_hand_tcp")
    pin.framesForwardKinematics(panda.model, data, q_before)
    np.testing.assert_allclose(state.frame_placement(fid).homogeneous, data.oMf[fid].homogeneous)


@pytest.mark.parametrize("name", ["data", "robot", "collision_data"])
def test_data_model_and_robot_cannot_be_replaced(panda: Robot, planar: Robot, name: str) -> None:
    state = panda.state()
    other = planar.state()
    with pytest.raises(InvalidInputError, match=r"read-only|collision model"):
        setattr(state, name, getattr(other, name))
    assert getattr(state, name) is not getattr(other, name)


def test_collision_data_of_the_same_model_is_accepted(panda: Robot) -> None:
    state = panda.state()
    fresh = panda.collision_model.createData()
    state.collision_data = fresh
    assert state.collision_data is fresh
    with pytest.raises(InvalidInputError, match="createData"):
        state.collision_data = panda.model.createData()  # a pin.Data, not a GeometryData


def test_state_of_another_robot_is_refused_by_the_solvers(panda: Robot, planar: Robot) -> None:
    from taskspace.features import FramePose
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.tasks import Task

    state = panda.state()
    for native in (True, False):
        task = Task(FramePose(panda, "panda_hand_tcp"))
        task.set_target_from_state(state)
        ik = DifferentialIK(panda, [task], options=DifferentialIKOptions(native=native))
        with pytest.raises(TaskspaceError, match="planar_2link"):
            ik.solve(planar.state(), 0.01)


@pytest.mark.parametrize(
    ("method", "count"),
    [
        ("frame_placement", "nframes"),
        ("frame_jacobian", "nframes"),
        ("frame_jacobian_local", "nframes"),
    ],
)
@pytest.mark.parametrize("index", [10**6, -1, 2.5, True, "3", [1], None])
def test_bad_frame_index_lists_the_valid_range(
    panda: Robot, method: str, count: str, index: object
) -> None:
    state = panda.state()
    n = getattr(panda.model, count)
    with pytest.raises(InvalidInputError) as info:
        getattr(state, method)(index)
    if isinstance(index, int) and not isinstance(index, bool):
        assert f"0..{n - 1}" in str(info.value)
    else:
        assert f"[0, {n - 1}]" in str(info.value)
    assert "frame_id(name)" in str(info.value)


def test_numpy_integer_indices_are_accepted(panda: Robot) -> None:
    q = _q(panda, 3)
    state = panda.state(q)
    fid = panda.frame_id("panda_hand_tcp")
    data = panda.model.createData()
    ref = pin.computeFrameJacobian(panda.model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(state.frame_jacobian(np.int64(fid)), ref, atol=1e-12)
    np.testing.assert_allclose(
        state.frame_placement(np.int32(fid)).translation, data.oMf[fid].translation, atol=1e-12
    )


_CRASHERS = textwrap.dedent(
    """
    import numpy as np
    from taskspace.errors import TaskspaceError
    from taskspace.features import FramePose
    from taskspace.ik import DifferentialIK
    from taskspace.model import Robot
    from taskspace.tasks import Task

    panda, planar = Robot.load("panda"), Robot.load("planar_2link")
    state = panda.state(panda.q_default, np.zeros(panda.nv))
    for call in (
        lambda: state.joint_jacobian_world(10**6),
        lambda: state.frame_drift(10**6),
        lambda: state.frame_drift_local(-1),
    ):
        try:
            call()
            print("accepted")
        except TaskspaceError as exc:
            print("refused", "0.." in str(exc))
    task = Task(FramePose(panda, "panda_hand_tcp"))
    task.set_target_from_state(state)
    ik = DifferentialIK(panda, [task])
    try:
        state.data = planar.model.createData()
        print("swapped")
    except TaskspaceError:
        print("refused", True)
    state.update(panda.q_default)  # with a swapped data: errors from inside Pinocchio
    q, result = ik.step(state, 0.01)  # or an abort of the process (issue #15)
    print("stepped", bool(result.success))
    """
)


def test_crashing_calls_raise_instead() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _CRASHERS], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split("\n")[:5] == ["refused True"] * 4 + ["stepped True"], proc.stdout


def test_collision_data_follows_the_world_made_at_first_use() -> None:
    # a state's GeometryData is made when first read or queried, for the world of that moment;
    # read again after an obstacle change, it is a new one of the new collision model, and the
    # distances are Pinocchio's on a fresh data
    from taskspace.model import Obstacle

    robot = Robot.load("panda", convex_collision=True)
    state = robot.state(_q(robot, 3))
    wall = pin.SE3(np.eye(3), np.r_[0.5, 0, 0.5])
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 1.0], wall))
    geom = robot._collision_model
    before = state.collision_data
    assert len(before.oMg) == geom.ngeoms
    assert len(before.distanceResults) == len(geom.collisionPairs)
    assert state.collision_data is before  # no change: the same data
    robot.add_obstacle(Obstacle.sphere("ball", 0.1, pin.SE3(np.eye(3), np.r_[0, 0.4, 0.6])))
    after = state.collision_data
    assert after is not before and len(after.distanceResults) == len(geom.collisionPairs)
    got = [r.min_distance for r in state.distance_results()]
    ref = geom.createData()
    pin.computeDistances(robot._model, robot._model.createData(), geom, ref, state.q)
    np.testing.assert_allclose(got, [r.min_distance for r in ref.distanceResults], atol=1e-9)
