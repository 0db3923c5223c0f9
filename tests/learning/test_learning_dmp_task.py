from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.features import FramePose, JointConfiguration, Position
from taskspace.ik import DifferentialIK
from taskspace.learning import DiscreteDMP, DMPTaskTarget, SphereRepulsion
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task


def _line_demo(start: np.ndarray, goal: np.ndarray, duration: float = 1.0):  # type: ignore[no-untyped-def]
    t = np.linspace(0, duration, 201)
    s = t / duration
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    return t, start + mj[:, None] * (goal - start)


def _point_task() -> Task:
    # A 3-vector target: the joint configuration of the planar 3-link arm.
    return Task(JointConfiguration(Robot.load("planar_3link")), np.zeros(3))


def test_online_steps_reproduce_the_rollout_and_set_the_target() -> None:
    t, Y = _line_demo(np.zeros(3), np.array([0.3, -0.2, 0.5]))
    dmp = DiscreteDMP.fit(t, Y)
    task = _point_task()
    driver = DMPTaskTarget(dmp, task)
    dt = 0.002
    ref = dmp.rollout(dt, duration=1.2, yd0=np.zeros(3))
    for k in range(1, ref.time.size):
        step = driver.step(dt)
        assert step.y == pytest.approx(ref.y[k], abs=1e-12)
        assert step.yd == pytest.approx(ref.yd[k], abs=1e-9)
        assert task.target == pytest.approx(step.y)
        assert task.reference_velocity == pytest.approx(step.yd)
    assert driver.y == pytest.approx(Y[-1], abs=2e-3)


def test_sphere_repulsion_is_the_negative_gradient_of_its_potential() -> None:
    rep = SphereRepulsion(center=[0.1, 0.2, 0.3], radius=0.05, influence=0.1, gain=2e-3)
    rng = np.random.default_rng(1)
    h = 1e-7
    checked = 0
    for _ in range(200):
        y = rep.center + rng.normal(size=3) * 0.1
        d = rep.distance(y)
        if not 0.005 < d < 0.095:
            continue
        fd = [(rep.potential(y - h * e) - rep.potential(y + h * e)) / (2 * h) for e in np.eye(3)]
        assert rep.term(y, np.zeros(3)) == pytest.approx(fd, rel=1e-5, abs=1e-9)
        checked += 1
    assert checked > 20
    far = rep.center + np.array([0.2, 0.0, 0.0])
    assert rep.potential(far) == 0.0 and np.all(rep.term(far, np.zeros(3)) == 0.0)
    ball = Obstacle.sphere("ball", 0.05, [0.1, 0.2, 0.3])
    assert SphereRepulsion.from_obstacle(ball).center == pytest.approx(rep.center)
    with pytest.raises(InvalidInputError, match="sphere"):
        SphereRepulsion.from_obstacle(Obstacle.box("box", [0.1, 0.1, 0.1]))


def test_obstacle_coupling_goes_around_a_sphere_on_the_path() -> None:
    start, goal = np.zeros(3), np.array([1.0, 0.0, 0.0])
    t, Y = _line_demo(start, goal)
    dmp = DiscreteDMP.fit(t, Y)
    ball = SphereRepulsion(center=[0.5, 0.02, 0.01], radius=0.1, influence=0.15, gain=2e-3)
    dists = {}
    for coupled in (False, True):
        driver = DMPTaskTarget(dmp, _point_task(), couplings=[ball] if coupled else [])
        path = np.array([driver.step(0.002).y for _ in range(1500)])
        dists[coupled] = min(ball.distance(y) for y in path)
        final = path[-1]
    # The demonstrated straight line goes through the sphere; the coupled DMP passes it
    # outside and still converges to the goal.
    assert dists[False] < -0.05
    assert dists[True] > 0.0
    assert final == pytest.approx(goal, abs=1e-2)


@pytest.mark.parametrize("pose", [False, True])
def test_dmp_drives_the_panda_tcp_through_differential_ik(panda: Robot, pose: bool) -> None:
    state = panda.state()
    start = panda.frame_placement(panda.q_default, "panda_hand_tcp")
    goal = start.translation + np.array([0.1, 0.25, -0.1])
    t, Y = _line_demo(start.translation, goal)
    dmp = DiscreteDMP.fit(t, Y)
    feature = FramePose(panda, "panda_hand_tcp") if pose else Position(panda, "panda_hand_tcp")
    task = Task(feature, start if pose else start.translation)
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-4)
    driver = DMPTaskTarget(dmp, task)
    ik = DifferentialIK(panda, [task, posture])
    err = 0.0
    dt = 0.01
    for _ in range(150):
        step = driver.step(dt)
        q, _ = ik.step(state, dt)
        state.update(q)
        tcp = pin.SE3(panda.frame_placement(q, "panda_hand_tcp"))  # Pinocchio's FK
        err = max(err, float(np.linalg.norm(tcp.translation - step.y)))
        if pose:
            assert np.linalg.norm(pin.log3(tcp.rotation.T @ start.rotation)) < 1e-3
    assert err < 2e-3
    assert (
        np.linalg.norm(panda.frame_placement(state.q, "panda_hand_tcp").translation - goal) < 5e-3
    )


def test_errors(panda: Robot) -> None:
    t, Y = _line_demo(np.zeros(2), np.ones(2))
    dmp = DiscreteDMP.fit(t, Y)
    with pytest.raises(InvalidInputError, match="3 dimensions but the DMP 2"):
        DMPTaskTarget(dmp, Task(Position(panda, "panda_hand_tcp")))
    with pytest.raises(InvalidInputError, match="3-D DMP"):
        DMPTaskTarget(dmp, Task(FramePose(panda, "panda_hand_tcp")))
    with pytest.raises(InvalidInputError, match="term"):
        dmp3 = DiscreteDMP.fit(*_line_demo(np.zeros(3), np.ones(3)))
        DMPTaskTarget(dmp3, Task(Position(panda, "panda_hand_tcp")), couplings=[object()])  # type: ignore[list-item]
    with pytest.raises(InvalidInputError, match="radius"):
        SphereRepulsion(center=[0, 0, 0], radius=-1.0)
