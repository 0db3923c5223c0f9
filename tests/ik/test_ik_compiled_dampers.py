"""The compiled IK kernel with collision velocity dampers (coal distances in the kernel).

References are independent of the kernel: coal distances and finite differences of them
(computed here in Python), the Python path solved with quadprog (an exact dual active-set
solver), and the KKT conditions of the Python path's QP checked here with NumPy.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import CollisionAvoidance, JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Obstacle, Robot
from taskspace.qp.solver import QPSolverOptions, available_backends
from taskspace.tasks import Task

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")

DT = 0.01
SAFETY, INFLUENCE, GAIN = 0.02, 0.12, 0.5


def _scene(native: bool = True, backend: str = "proxsuite") -> dict:  # type: ignore[type-arg]
    """The main demo's scene: Panda (convex collision), a ball and a box, every pair."""
    robot = Robot.load("panda", convex_collision=True)  # private copy: obstacles are added
    tcp = robot.end_effectors[0]
    state = robot.state(robot.q_default)
    start = state.frame_placement(robot.frame_id(tcp)).copy()
    robot.add_obstacle(
        Obstacle.sphere("ball", 0.07, start.translation + np.array([0.0, 0.22, -0.03]))
    )
    robot.add_obstacle(
        Obstacle.box("block", [0.1, 0.1, 0.1], pin.SE3(np.eye(3), np.array([0.45, -0.3, 0.3])))
    )
    pose = Task(F.FramePose(robot, tcp), weight=1.0, gain=0.5, name="tcp")
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-5, name="posture")
    avoid = CollisionAvoidance(
        robot, safety_distance=SAFETY, influence_distance=INFLUENCE, gain=GAIN
    )
    options = DifferentialIKOptions(native=native, solver=QPSolverOptions(backend=backend))
    ik = DifferentialIK(
        robot,
        [pose, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot), avoid],
        options=options,
    )
    return {"robot": robot, "ik": ik, "pose": pose, "avoid": avoid, "start": start}


def _coal_distances(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Signed distances of every collision pair at q, from coal (fresh data)."""
    data = robot.model.createData()
    geom = robot.collision_model
    gdata = geom.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    pin.updateGeometryPlacements(robot.model, data, geom, gdata)
    pin.computeDistances(geom, gdata)
    return np.array([r.min_distance for r in gdata.distanceResults])


def _random_states(robot: Robot, n: int, seed: int) -> list[np.ndarray]:
    """Random configurations outside the safety distance, half of them within 3 cm of it.

    (Inside the safety distance the damper rows exclude ``dq = 0``; the kernel then takes
    the Python path: :func:`test_inside_the_safety_distance_takes_the_python_path`.)
    """
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    while len(out) < n:
        q = robot.random_configuration(rng)
        d = _coal_distances(robot, q)
        if d.min() <= SAFETY:
            continue
        near = d.min() < SAFETY + 0.03
        if near or len(out) % 2 == 0:
            out.append(q)
    return out


def test_rows_match_coal_distances_and_their_finite_differences() -> None:
    s = _scene()
    robot, ik, avoid = s["robot"], s["ik"], s["avoid"]
    assert ik.native
    checked = 0
    for q in _random_states(robot, 12, seed=1):
        state = robot.state(q)
        s["pose"].set_target(state.frame_placement(robot.frame_id(robot.end_effectors[0])))
        result = ik.solve(state, DT)
        assert result.success and result.qp.backend == "native"
        C, l, u, pairs, dists = ik._native.damper_rows()
        d = _coal_distances(robot, q)
        expected = [k for k in range(len(d)) if d[k] < INFLUENCE]
        assert list(pairs) == expected  # no pair within the influence distance is culled
        np.testing.assert_allclose(dists, d[expected], atol=1e-9)
        np.testing.assert_allclose(l, -GAIN * (d[expected] - SAFETY), atol=1e-9)
        assert np.all(u >= 1e19)
        # each row is the gradient of the coal distance: central differences
        eps = 1e-6
        for row, k in zip(C, pairs):
            fd = np.empty(robot.nv)
            for i in range(robot.nv):
                e = np.zeros(robot.nv)
                e[i] = eps
                plus = _coal_distances(robot, pin.integrate(robot.model, q, e))[k]
                minus = _coal_distances(robot, pin.integrate(robot.model, q, -e))[k]
                fd[i] = (plus - minus) / (2 * eps)
            np.testing.assert_allclose(row, fd, atol=2e-4 * max(1.0, np.abs(fd).max()))
            checked += 1
        # and the rows of the Python path (CollisionAvoidance.inequalities)
        rows = avoid.inequalities(state, DT)
        np.testing.assert_allclose(C, rows[0], atol=1e-9)
    assert checked >= 10


def _kkt_numpy(problem, x, z, z_box) -> tuple[float, float, float]:  # type: ignore[no-untyped-def]
    """Primal, dual and complementarity residuals of the Python path's QP, in NumPy."""
    H, g, C, l, lb, ub = problem.H, problem.g, problem.C, problem.l, problem.lb, problem.ub
    Cx = C @ x
    primal = max(0.0, (l - Cx).max(initial=0.0), (lb - x).max(), (x - ub).max())
    dual = np.abs(H @ x + g + C.T @ z + z_box).max()
    # rows have only lower bounds (u = inf): z <= 0, zero where the row is inactive
    comp_rows = np.minimum(np.abs(z), np.where(z > 0, np.inf, np.abs(Cx - l)))
    slack_box = np.where(z_box > 0, np.abs(ub - x), np.abs(x - lb))
    comp_box = np.minimum(np.abs(z_box), slack_box)
    return primal, dual, max(comp_rows.max(initial=0.0), comp_box.max())


@pytest.mark.skipif("quadprog" not in available_backends(), reason="quadprog not installed")
def test_steps_match_quadprog_and_satisfy_kkt() -> None:
    s = _scene()
    ref = _scene(native=False, backend="quadprog")
    robot, ik = s["robot"], s["ik"]
    tcp = robot.frame_id(robot.end_effectors[0])
    rng = np.random.default_rng(2)
    binding = compiled = 0
    for q in _random_states(robot, 30, seed=3):
        state = robot.state(q)
        # a target about 30 cm away in a random direction
        target = state.frame_placement(tcp).copy()
        target.translation = target.translation + 0.3 * rng.normal(size=3) / np.sqrt(3)
        s["pose"].set_target(target)
        ref["pose"].set_target(target)
        result = ik.solve(state, DT)
        expected = ref["ik"].solve(ref["robot"].state(q), DT)
        assert result.success == expected.success  # infeasible steps: both relax
        if not expected.success:
            continue
        assert expected.qp.backend == "quadprog"
        compiled += result.qp.backend == "native"
        np.testing.assert_allclose(result.dq, expected.dq, atol=1e-7)
        if result.qp.backend != "native":
            continue
        kkt = result.qp.kkt
        assert kkt.within(1e-9, 1e-9)
        # KKT of the Python path's QP at the kernel's step and multipliers, in NumPy
        problem = ik.build(state, DT)
        z, z_box = ik._native.multipliers()
        if len(z_box) == 0:
            z_box = np.zeros(robot.nv)
        primal, dual, comp = _kkt_numpy(problem, result.dq, np.asarray(z), np.asarray(z_box))
        scale = max(1.0, np.abs(problem.g).max(), np.abs(problem.H @ result.dq).max())
        assert primal <= 1e-9 * scale
        assert dual <= 1e-8 * scale
        assert comp <= 1e-8 * scale
        assert np.all(np.asarray(z) <= 1e-12)  # lower bounds only: nonpositive multipliers
        binding += int(np.any(np.asarray(z) < -1e-9))
    assert binding >= 3  # dampers bind in several of the sampled steps
    assert compiled >= 25


def test_inside_the_safety_distance_takes_the_python_path() -> None:
    """Rows that exclude dq = 0 (a pair closer than the safety distance): the Python path."""
    s = _scene()
    robot, ik = s["robot"], s["ik"]
    rng = np.random.default_rng(5)
    seen = 0
    while seen < 3:
        q = robot.random_configuration(rng)
        d = _coal_distances(robot, q)
        if not 0.0 < d.min() < SAFETY:
            continue
        seen += 1
        state = robot.state(q)
        s["pose"].set_target(state.frame_placement(robot.frame_id(robot.end_effectors[0])))
        result = ik.solve(state, DT)
        assert result.qp.backend != "native"


def test_trajectory_behind_the_obstacle_never_penetrates() -> None:
    s = _scene()
    robot, ik, pose, start = s["robot"], s["ik"], s["pose"], s["start"]
    goal = start.copy()
    goal.translation = start.translation + np.array([0.0, 0.45, -0.05])  # behind the ball
    q = robot.q_default.copy()
    state = robot.state(q)
    native = 0
    smallest = np.inf
    for k in range(500):
        sk = min(1.0, k / 375)
        pose.set_target(pin.SE3.Interpolate(start, goal, 0.5 * (1 - np.cos(np.pi * sk))))
        state.update(q)
        result = ik.solve(state, DT)
        assert result.success
        native += result.qp.backend == "native"
        # the kernel's rows are those of every pair within the influence distance (its
        # culling by bounding volumes and by the motion since the last query is exact)
        d = _coal_distances(robot, q)
        _, _, _, pairs, dists = ik._native.damper_rows()
        assert pairs == [k for k in range(len(d)) if d[k] < INFLUENCE]
        # the kernel's distances do not depend on earlier queries (cached GJK guess off):
        # equal to those of fresh collision data (5e-8 m apart with the guess kept)
        np.testing.assert_allclose(dists, d[pairs], rtol=0, atol=1e-12)
        smallest = min(smallest, d.min())
        q = pin.integrate(robot.model, q, result.dq)
    smallest = min(smallest, _coal_distances(robot, q).min())
    assert smallest > 0.0  # never penetrates (coal, every pair)
    assert smallest > SAFETY - 0.005  # the dampers hold about the safety distance
    assert native >= 450  # the compiled path serves the trajectory
    state.update(q)
    assert np.linalg.norm(pose.error(state)[:3]) < 0.15  # it went around toward the goal


def test_declaration_selects_the_path() -> None:
    """A subclass that does not declare its rows itself is not evaluated by the kernel.

    Its rows are evaluated in Python (its own ``inequalities``) and solved by the general
    step; the class that declares them has them evaluated by the kernel.
    """

    class Custom(CollisionAvoidance):
        pass

    robot = Robot.load("panda", convex_collision=True)
    pose = Task(F.FramePose(robot, robot.end_effectors[0]), name="tcp")
    pose.set_target_from_state(robot.state(robot.q_default))
    declared = DifferentialIK(robot, [pose], [CollisionAvoidance(robot)])
    assert declared.native
    assert declared._native is not None and declared._native._general is None
    custom = DifferentialIK(robot, [pose], [Custom(robot)])
    if hasattr(ik_kernel(), "GeneralIKStep"):
        assert custom.native and custom._native is not None
        assert custom._native._rows == [] and custom._native._general is not None
    else:
        assert not custom.native


def test_an_obstacle_added_after_the_first_step_is_refused_as_on_the_python_path() -> None:
    """Dampers of every pair must be built again when the world changes (both paths say so)."""
    compiled, python = _scene(), _scene(native=False)
    for s in (compiled, python):
        robot, ik = s["robot"], s["ik"]
        state = robot.state(robot.q_default)
        tcp = state.frame_placement(robot.frame_id(robot.end_effectors[0]))
        s["pose"].set_target(tcp)
        assert ik.solve(state, DT).success
        robot.add_obstacle(
            Obstacle.sphere("low", 0.03, tcp.translation - np.array([0.0, 0.0, 0.08]))
        )
        with pytest.raises(InvalidInputError, match="obstacle world changed"):
            ik.solve(robot.state(robot.q_default), DT)
