"""MotionBenchMaker requests on the Panda (the scene set-up's ``problem.request``).

Reference: the request YAML read with PyYAML, each joint's coordinate found by Pinocchio
(``model.getJointId``, ``idx_q``); joints the model does not have (the locked fingers) are
ignored, the others keep the default configuration.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from taskspace.model import Robot
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
    PlanningRequest,
    _read_moveit_request,
    _request_on,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from tests.planning._mbm import ROOT, SKIP_REASON


def _reference(robot: Robot, path: object) -> tuple[np.ndarray, np.ndarray, list[str]]:
    with open(str(path)) as f:
        doc = yaml.safe_load(f)
    model = robot.model
    state = doc["start_state"]["joint_state"]
    start = robot.q_default.copy()
    ignored = set()
    for name, value in zip(state["name"], state["position"]):
        if model.existJointName(name):
            start[model.joints[model.getJointId(name)].idx_q] = value
        else:
            ignored.add(name)
    goal = start.copy()
    for c in doc["goal_constraints"][0]["joint_constraints"]:
        if model.existJointName(c["joint_name"]):
            goal[model.joints[model.getJointId(c["joint_name"])].idx_q] = c["position"]
        else:
            ignored.add(c["joint_name"])
    return start, goal, sorted(ignored)


@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_requests_match_the_files() -> None:
    robot = motionbenchmaker_panda()
    for scen in MOTIONBENCHMAKER_SCENARIOS:
        for problem in motionbenchmaker_problems(ROOT, scen, [1, 2, 3]):
            got = problem.request(robot)
            start, goal, ignored = _reference(robot, problem.request_path)
            np.testing.assert_array_equal(got.start, start, err_msg=f"{scen} {problem.index}")
            np.testing.assert_array_equal(got.goal, goal, err_msg=f"{scen} {problem.index}")
            assert got.ignored_joints == ignored == ["panda_finger_joint1", "panda_finger_joint2"]
            assert isinstance(got, PlanningRequest)
            assert not np.shares_memory(got.start, got.goal)


@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_a_request_on_a_robot_with_the_fingers() -> None:
    """The registry Panda keeps its finger joints (locked closed in the model? then ignored):
    whatever the model has is set from the file, the rest is ignored."""
    robot = Robot.load("panda")
    problem = motionbenchmaker_problems(ROOT, "box", [1])[0]
    got = _request_on(robot, _read_moveit_request(problem.request_path))
    start, goal, ignored = _reference(robot, problem.request_path)
    np.testing.assert_array_equal(got.start, start)
    np.testing.assert_array_equal(got.goal, goal)
    assert got.ignored_joints == ignored
