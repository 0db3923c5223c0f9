"""Objects derived from a robot's limits follow ``Robot.set_limits`` (issue 15, item 1).

Each object copies limits when it is built. After ``robot.set_limits(...)`` (a new
``robot.version``) the next call must use the new limits or raise ``StaleModelError``; before
this change every one of them kept answering with the old limits. The reference is always
Pinocchio's own model (``robot.model.lowerPositionLimit``...), which ``set_limits`` writes.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.features import JointConfiguration
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.model.versioning import ModelFollower
from taskspace.planning import ConfigurationSpace, PRMOptions, build_prm, prm_query
from taskspace.planning.joint_manifold import JointManifold
from taskspace.tasks import Task
from taskspace.trajopt.path_optimization import PathProblem


def _fresh(name: str = "panda", geometry: bool = False) -> Robot:
    """A robot of its own (these tests change its limits)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load(name, geometry=geometry)


def _set_limits(robot: Robot, **kwargs: object) -> int:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the default posture may be clipped (ModelWarning)
        return robot.set_limits(**kwargs)


def _model_limits(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """The reference: Pinocchio's model arrays."""
    return np.array(robot.model.lowerPositionLimit), np.array(robot.model.upperPositionLimit)


def _narrow_joint(robot: Robot, i: int, lo: float, hi: float) -> None:
    lower, upper = robot.lower_limits.copy(), robot.upper_limits.copy()
    lower[i], upper[i] = lo, hi
    _set_limits(robot, lower=lower, upper=upper)


# ---------------------------------------------------------------------- the mechanism
def test_follower_rederives_once_per_version_or_raises() -> None:
    robot = _fresh()
    calls: list[int] = []
    follower = ModelFollower(robot, "Thing", lambda: calls.append(robot.version))
    assert calls == [robot.version] and not follower.sync() and not follower.stale
    _set_limits(robot, velocity=robot.velocity_limits)
    assert follower.stale and follower.sync() and calls[-1] == robot.version
    assert not follower.sync() and len(calls) == 2  # one comparison while current
    strict = ModelFollower(robot, "StrictThing", what_to_do="call strict.rebuild()")
    strict.sync()
    _set_limits(robot, velocity=robot.velocity_limits)
    with pytest.raises(StaleModelError, match=r"StrictThing was built for version .* strict"):
        strict.sync()
    with pytest.raises(StaleModelError):  # still stale: never silently accepted
        strict.sync()


# ---------------------------------------------------------------------- constraints
def test_joint_position_limits_follow_set_limits() -> None:
    robot = _fresh()
    c = JointPositionLimits(robot, margin=0.01)
    q = robot.q_default.copy()
    state = robot.state(q)
    _narrow_joint(robot, 3, -2.5, -2.2)
    lo, hi = _model_limits(robot)
    box = c.bounds(state, 0.01)
    np.testing.assert_allclose(box.lower[3], lo[3] + 0.01 - q[3])
    np.testing.assert_allclose(box.upper[3], hi[3] - 0.01 - q[3])
    iq, _, low, high, _ = c.kernel_arguments()
    assert low[iq.index(3)] == pytest.approx(lo[3] + 0.01)
    assert high[iq.index(3)] == pytest.approx(hi[3] - 0.01)
    # new limits the margin no longer fits in: refused now and at every later call
    _narrow_joint(robot, 3, -2.3, -2.29)
    for _ in range(2):
        with pytest.raises(InvalidInputError, match=r"margin 0\.01 is larger than half"):
            c.bounds(state, 0.01)


def test_joint_velocity_limits_follow_the_robot_unless_given() -> None:
    robot = _fresh()
    follows = JointVelocityLimits(robot, scale=0.5)
    given = JointVelocityLimits(robot, limits=np.full(robot.nv, 1.0))
    state = robot.state(robot.q_default)
    assert follows.bounds(state, 0.1).upper[0] == pytest.approx(0.05 * robot.velocity_limits[0])
    velocity = robot.velocity_limits.copy()
    velocity[0] = 0.2
    _set_limits(robot, velocity=velocity)
    assert np.array(robot.model.velocityLimit)[0] == 0.2
    # same dt as before: the cached box must not be returned
    assert follows.bounds(state, 0.1).upper[0] == pytest.approx(0.5 * 0.2 * 0.1)
    assert follows.limits[0] == pytest.approx(0.1)
    assert given.bounds(state, 0.1).upper[0] == pytest.approx(0.1)  # the user's limits


def test_floating_base_velocity_limits_keep_base_limits() -> None:
    robot = _fresh("solo12")
    c = JointVelocityLimits(robot, base_limits=np.full(6, 2.0))
    velocity = robot.velocity_limits.copy()
    velocity[6] = 0.3
    _set_limits(robot, velocity=velocity)
    lim = c.limits
    assert lim[6] == 0.3 and np.all(lim[:6] == 2.0)


@pytest.mark.parametrize("native", [False, True])
def test_differential_ik_steps_respect_new_limits(native: bool) -> None:
    """The compiled kernel keeps a copy of the limits: it is sent again after set_limits."""
    if native and ik_kernel() is None:
        pytest.skip("the compiled IK kernel is not built")
    robot = _fresh()
    q = robot.q_default.copy()
    target = q.copy()
    target[0] = q[0] + 1.0  # the posture pulls joint 1 far up
    ik = DifferentialIK(
        robot,
        [Task(JointConfiguration(robot), target)],
        [JointPositionLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )
    state = robot.state(q)
    q1, _ = ik.step(state, 1.0)
    assert q1[0] == pytest.approx(target[0], abs=1e-6)  # free: the whole way
    assert ik.native is native
    _narrow_joint(robot, 0, q[0] - 0.5, q[0] + 0.2)
    _, hi = _model_limits(robot)
    q2, result = ik.step(state, 1.0)
    assert result.success
    assert q2[0] == pytest.approx(hi[0], abs=1e-6)  # stopped at the new limit


# ---------------------------------------------------------------------- planning
def test_joint_manifold_follows_the_robot_and_refuses_a_changed_bare_model() -> None:
    robot = _fresh("ur5")
    followed = JointManifold(robot)
    model = robot.model  # a copy: the robot's changes do not reach it, edits of it do
    bare = JointManifold(model)
    version = followed.model_version
    _narrow_joint(robot, 2, 0.1, 0.3)
    lo, hi = _model_limits(robot)
    assert followed.model_version == robot.version != version
    np.testing.assert_array_equal(followed.lower, lo)
    np.testing.assert_array_equal(followed.upper, hi)
    samples = followed.sample(np.random.default_rng(0), 200)
    assert np.all((samples[:, 2] >= 0.1) & (samples[:, 2] <= 0.3))
    assert bare.lower[2] != 0.1  # its model is the robot's copy from before the change
    model.lowerPositionLimit[2] = 0.1  # an edit of the bare model itself is refused
    for use in (lambda: bare.lower, lambda: bare.sample(np.random.default_rng(0), 3)):
        with pytest.raises(StaleModelError, match="bare Pinocchio model"):
            use()


def test_configuration_space_follows_the_robot() -> None:
    robot = _fresh("ur5", geometry=True)
    space = ConfigurationSpace.from_robot(robot)
    assert space.is_euclidean
    q = robot.q_default.copy()
    q[2] = 1.0
    space.check_endpoint(q, "start")
    _narrow_joint(robot, 2, 0.1, 0.3)
    lo, hi = _model_limits(robot)
    np.testing.assert_array_equal(space.lower, lo)
    np.testing.assert_array_equal(space.upper, hi)
    samples = space.sample_uniform(np.random.default_rng(1), 300)
    assert np.all((samples[:, 2] >= 0.1) & (samples[:, 2] <= 0.3))
    assert not space.within_bounds(q)
    with pytest.raises(Exception, match="outside the joint limits"):
        space.check_endpoint(q, "start")
    # a joint made unbounded cannot stay in a box: refused until the limits are planable
    upper = robot.upper_limits.copy()
    upper[2] = np.inf
    _set_limits(robot, upper=upper)
    for _ in range(2):
        with pytest.raises(InvalidInputError, match="no finite position limits"):
            space.sample_uniform(np.random.default_rng(1), 3)


def test_roadmap_of_old_limits_is_refused() -> None:
    robot = _fresh("ur5", geometry=True)
    space = ConfigurationSpace.from_robot(robot)
    options = PRMOptions(max_iterations=30, k_neighbors=5, seed=3)
    roadmap = build_prm(space, options)
    assert roadmap.model_version == robot.version
    start, goal = roadmap.nodes[0], roadmap.nodes[1]
    prm_query(space, roadmap, start, goal, options)
    lower = robot.lower_limits.copy()
    lower[0] = 0.0
    _set_limits(robot, lower=lower)
    with pytest.raises(StaleModelError, match="roadmap was built for version"):
        prm_query(space, roadmap, robot.q_default, robot.q_default, options)


# ---------------------------------------------------------------------- path optimization
def test_path_problem_limit_rows_follow_set_limits() -> None:
    robot = _fresh()
    q = robot.q_default.copy()
    problem = PathProblem(robot, q, 3, joint_limits=True)
    path = np.tile(q, (4, 1))
    assert np.all(problem.residual(path) == 0.0)  # inside the limits, at rest
    _narrow_joint(robot, 3, q[3] + 0.1, q[3] + 0.4)  # q[3] now 0.1 below its lower limit
    lo, _ = _model_limits(robot)
    r = problem.residual(path)
    # one violated row per slice: lower[3] - q[3] (penalty 1, zero multipliers)
    np.testing.assert_allclose(np.sort(r[r != 0.0]), np.full(3, lo[3] - q[3]))
    assert len(problem.zero_multipliers().inequality[0]) == 2 * robot.limited_joints_q.size


def test_space_on_a_bare_model_manifold_refuses_plans_after_a_change() -> None:
    """A space made by hand on a bare model refuses once that model's limits change."""
    from taskspace.planning.collision_checker import FunctionChecker

    robot = _fresh("ur5")
    model = robot.model
    manifold = JointManifold(model)
    free = FunctionChecker(lambda Q: np.ones(len(Q), dtype=bool))
    space = ConfigurationSpace(manifold.lower, manifold.upper, free, manifold=manifold)
    q = robot.q_default.copy()
    space.check_endpoint(q, "start")
    _narrow_joint(robot, 2, 0.1, 0.3)
    space.check_endpoint(q, "start")  # the robot's change does not reach the copy
    model.lowerPositionLimit[2] = 0.1  # a change of the bare model itself
    with pytest.raises(StaleModelError, match="bare Pinocchio model"):
        space.check_endpoint(q, "start")
    with pytest.raises(StaleModelError):
        space.sample_uniform(np.random.default_rng(0), 2)


def test_a_deep_copy_of_a_space_follows_its_own_robot() -> None:
    """copy.deepcopy copies the robot: the copy re-derives itself, the original is untouched."""
    import copy

    robot = _fresh("ur5", geometry=True)
    space = ConfigurationSpace.from_robot(robot)
    twin = copy.deepcopy(space)
    twin_robot = twin._follower.robot  # type: ignore[union-attr]
    assert twin_robot is not robot
    _narrow_joint(twin_robot, 2, 0.1, 0.3)
    assert twin.lower[2] == 0.1 and twin.upper[2] == 0.3
    np.testing.assert_array_equal(space.lower, robot.lower_limits)  # the original is unchanged
