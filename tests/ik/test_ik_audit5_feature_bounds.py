"""FeatureBounds and FeatureGoalRegion on features whose value is not a vector (audit5).

``FeatureBounds`` documents "a feature whose value is a vector (not a pose)" but accepted a
frame pose, an orientation, a relative pose, the configuration of a robot with continuous
joints and a configuration of selected joints (its value is the whole q); every step then
failed with a bare numpy ValueError, a Boost.Python TypeError or an
IndexError (Python path, compiled IK and hierarchy alike).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK, DifferentialIKOptions, FeatureGoalRegion, HierarchicalIK
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot


def _kinova() -> Robot:
    with pytest.warns(Warning):  # kinova's SRDF leaves colliding pairs (a ModelWarning)
        return Robot.load("kinova")


def _not_vectors() -> list[tuple[str, F.Feature]]:
    panda = load_robot("panda")
    ee = panda.end_effectors[0]
    kinova = _kinova()  # continuous joints: q has 9 entries, the tangent 6
    return [
        ("frame pose", F.FramePose(panda, ee)),
        ("orientation", F.Orientation(panda, ee)),
        ("relative pose", F.RelativeFramePose(panda, ee, "panda_link3")),
        ("configuration with continuous joints", F.JointConfiguration(kinova)),
        # the value is the whole q (size 7) for a selection of dim 1: the compiled step said
        # "inequality rows: sizes differ", the Python step raised a numpy ValueError
        ("selected joints", F.JointConfiguration(panda, ["panda_joint2"])),
        ("kinova's bounded joint", F.JointConfiguration(kinova, ["j2s6s200_joint_2"])),
    ]


@pytest.mark.parametrize("index", range(6))
def test_feature_bounds_refuses_a_feature_whose_value_is_not_a_vector(index: int) -> None:
    label, feature = _not_vectors()[index]
    with pytest.raises(InvalidInputError, match="value is not a vector") as info:
        FeatureBounds(feature, -0.5, 0.5)
    assert feature.name in str(info.value), label


@pytest.mark.parametrize("native", [True, False])
def test_feature_bounds_on_a_pose_never_reaches_the_step(native: bool) -> None:
    # before: the constraint was built and the step raised a bare ValueError
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    task = Task(F.Position(robot, ee), [0.3, 0.2, 0.5])
    with pytest.raises(InvalidInputError):
        ik = DifferentialIK(
            robot,
            [task],
            [FeatureBounds(F.FramePose(robot, ee), -0.01, 0.01)],
            options=DifferentialIKOptions(native=native),
        )
        ik.solve(robot.state(robot.q_default), 0.01)
    with pytest.raises(InvalidInputError):
        HierarchicalIK(robot, [[FeatureBounds(F.Orientation(robot, ee), -1, 1)], [task]])


def test_feature_bounds_on_vector_features_still_accepted() -> None:
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    for feature in (
        F.JointConfiguration(robot),  # every joint, all revolute: q is a vector
        F.Position(robot, ee),
        F.CenterOfMass(robot),
        F.RelativePosition(robot, ee, "panda_link3"),
    ):
        bounds = FeatureBounds(feature, -5.0, 5.0)
        rows = bounds.inequalities(feature.robot.state(feature.robot.q_default), 0.01)
        assert rows.C.shape == (feature.dim, feature.robot.nv)
        assert np.all(rows.lower < 0) and np.all(rows.upper > 0)


def test_feature_goal_region_names_the_value_shape() -> None:
    # the message said only "has values of type ndarray" for the kinova configuration
    kinova = _kinova()
    with pytest.raises(InvalidInputError, match=r"shape \(9,\).*dim 6"):
        FeatureGoalRegion(F.JointConfiguration(kinova), -0.5, 0.5)
