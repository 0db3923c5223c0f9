"""URDFs a new user meets: mimic joints, equal (missing) limits, and set_limits that pins a joint.

* A URDF ``<mimic>`` joint is an independent joint in the model (Pinocchio's default): loading
  says so with a :class:`ModelWarning` naming the joint and its rule, unless it is locked.
* Equal lower and upper limits are read as "no limit" (a URDF's missing ``lower``/``upper``
  are 0, 0: centauro's wheels, double_pendulum): loading names those joints in a warning.
* ``Robot.set_limits`` with ``lower == upper`` used to make the joint silently unlimited
  (sampled on the whole circle, any value accepted by ``check_limits``): now refused.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from taskspace import InvalidInputError
from taskspace.errors import ModelWarning
from taskspace.model import Robot

LIMIT = '<limit lower="-1" upper="1" effort="10" velocity="2"/>'
LINK = (
    '<link name="{0}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" '
    'ixy="0" ixz="0" iyz="0"/></inertial></link>'
)


def _joint(name: str, parent: str, child: str, extra: str) -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>{extra}</joint>'
    )


def _urdf(tmp_path: Path, j1: str, j2: str) -> Path:
    links = "".join(LINK.format(n) for n in ("base", "l1", "l2"))
    joints = _joint("j1", "base", "l1", j1) + _joint("j2", "l1", "l2", j2)
    text = f'<robot name="r">{links}{joints}</robot>'
    path = tmp_path / "r.urdf"
    path.write_text(text)
    return path


def _warnings(load) -> tuple[Robot, list[str]]:  # type: ignore[no-untyped-def]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load()
    return robot, [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]


def test_a_mimic_joint_is_named_on_load(tmp_path: Path) -> None:
    path = _urdf(tmp_path, LIMIT, LIMIT + '<mimic joint="j1" multiplier="2" offset="0.1"/>')
    robot, messages = _warnings(lambda: Robot.from_urdf(path))
    [message] = [m for m in messages if "mimic" in m]
    assert "j2 (= 2 * j1 + 0.1)" in message and "independent" in message
    # what the warning says: Pinocchio's model has j2 as a joint of its own
    assert robot.nq == 2 and robot.model.joints[2].shortname() == "JointModelRZ"
    _, messages = _warnings(lambda: Robot.from_urdf(path, locked_joints=["j2"]))
    assert not [m for m in messages if "mimic" in m]


def test_equal_limits_are_named_on_load(tmp_path: Path) -> None:
    path = _urdf(tmp_path, LIMIT, '<limit effort="10" velocity="2"/>')  # lower = upper = 0
    robot, messages = _warnings(lambda: Robot.from_urdf(path))
    assert any("equal lower and upper limits (j2=0)" in m for m in messages), messages
    # j2 is unlimited to the robot: sampled on the circle
    rng = np.random.default_rng(0)
    samples = np.array([robot.random_configuration(rng)[1] for _ in range(50)])
    assert samples.max() - samples.min() > 3.0
    # a change of other limits keeps the URDF's equal ones
    robot.set_limits(velocity=np.ones(2))


@pytest.mark.filterwarnings("ignore:.*default posture is outside")
def test_set_limits_refuses_lower_equal_to_upper() -> None:
    model = pin.Model()
    inertia = pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3)
    parent = 0
    for name in ("a", "b"):
        parent = model.addJoint(
            parent,
            pin.JointModelRY(),
            pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.3])),
            name,
            np.ones(1),
            np.ones(1),
            -np.ones(1),
            np.ones(1),
        )
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    empty = pin.GeometryModel()
    robot = Robot(model, empty, empty.copy(), name="two")
    version = robot.version
    lower = robot.lower_limits.copy()
    upper = robot.upper_limits.copy()
    lower[1] = upper[1] = 0.3
    with pytest.raises(
        InvalidInputError, match=r"lower == upper at configuration indices \[1\] \(joints b\).*lock"
    ):
        robot.set_limits(lower=lower, upper=upper)
    assert robot.version == version  # unchanged
    np.testing.assert_array_equal(robot.limited_joints_q, [0, 1])
    with pytest.raises(InvalidInputError, match="lower == upper"):
        with robot.edit_model() as edited:
            edited.lowerPositionLimit = lower
            edited.upperPositionLimit = upper
    # a narrow range is a range: samples stay in it
    lower[1], upper[1] = 0.3, 0.3 + 1e-6
    robot.set_limits(lower=lower, upper=upper)
    rng = np.random.default_rng(1)
    q = np.array([robot.random_configuration(rng)[1] for _ in range(20)])
    assert np.all((q >= 0.3) & (q <= 0.3 + 1e-6))
