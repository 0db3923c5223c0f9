"""Malformed URDF and SRDF files give a ModelLoadError that names the file, the line and why.

The line numbers are those of the hand-written files below (counted by hand, not by the code
under test); the "not physical" URDFs (lower limit above the upper one, negative mass) are
loaded silently by Pinocchio and must be refused as well.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from taskspace import ModelLoadError
from taskspace.model import Robot

INERTIA = '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
GOOD = f"""<robot name="t">
  <link name="base"/>
  <link name="l1">
    <inertial><mass value="1"/>{INERTIA}</inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="5" velocity="1"/>
  </joint>
</robot>
"""

# (label, edit of GOOD, line, message)
URDF_CASES = [
    ("truncated", lambda s: s[: s.index("<axis")], 9, "not well-formed XML"),
    ("unclosed joint", lambda s: s.replace("</joint>", ""), 12, "not well-formed XML"),
    ("empty", lambda s: "", 1, "not well-formed XML"),
    ("root", lambda s: "<robots/>", 1, "root element is <robots>"),
    ("type", lambda s: s.replace('"revolute"', '"rotary"'), 6, "unknown type 'rotary'"),
    ("parent", lambda s: s.replace('link="base"/>', 'link="bse"/>'), 7, "parent link 'bse'"),
    ("child", lambda s: s.replace('<child link="l1"/>', ""), 6, r"no <child link=\.\.\.>"),
    ("number", lambda s: s.replace('upper="3"', 'upper="3,0"'), 10, "upper='3,0'> is not a"),
    ("nan limit", lambda s: s.replace('upper="3"', 'upper="nan"'), 10, "limit upper is NaN"),
    ("lower > upper", lambda s: s.replace('lower="-3"', 'lower="4"'), 10, "lower limit 4 is above"),
    ("negative mass", lambda s: s.replace('value="1"', 'value="-2"'), 4, "mass -2 is not >= 0"),
]


@pytest.mark.parametrize(
    ("edit", "line", "message"), [c[1:] for c in URDF_CASES], ids=[c[0] for c in URDF_CASES]
)
def test_urdf_errors_give_file_and_line(tmp_path: Path, edit, line: int, message: str) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "robot.urdf"
    path.write_text(edit(GOOD))
    with pytest.raises(ModelLoadError, match=re.escape(f"{path}:{line}: ") + ".*" + message):
        Robot.from_urdf(path)


def test_good_urdf_loads_with_its_limits(tmp_path: Path) -> None:
    path = tmp_path / "robot.urdf"
    path.write_text(GOOD)
    robot = Robot.from_urdf(path)
    assert (robot.model.lowerPositionLimit[0], robot.model.upperPositionLimit[0]) == (-3.0, 3.0)


SRDF_CASES = [
    (
        "truncated",
        "<robot name='t'>\n<disable_collisions link1='base' link2=",
        2,
        "not well-formed",
    ),
    ("not xml", "hello", 1, "not well-formed XML"),
    ("root", "<srdf/>", 1, "root element is <srdf>"),
    (
        "value",
        "<robot name='t'>\n<group_state name='home' group='all'>\n"
        "<joint name='j1' value='abc'/>\n</group_state>\n</robot>",
        3,
        "group_state 'home': joint 'j1' value 'abc' is not a number",
    ),
]


@pytest.mark.parametrize(
    ("text", "line", "message"), [c[1:] for c in SRDF_CASES], ids=[c[0] for c in SRDF_CASES]
)
def test_srdf_errors_give_file_and_line(tmp_path: Path, text: str, line: int, message: str) -> None:
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(GOOD)
    srdf = tmp_path / "robot.srdf"
    srdf.write_text(text)
    with pytest.raises(ModelLoadError, match=re.escape(f"{srdf}:{line}: ") + ".*" + message):
        Robot.from_urdf(urdf, srdf=srdf)


def test_srdf_with_names_of_another_variant_loads(tmp_path: Path) -> None:
    """Unknown links and joints are ignored, as Pinocchio does (shared SRDFs of variants)."""
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(GOOD)
    srdf = tmp_path / "robot.srdf"
    srdf.write_text(
        "<robot name='t'><disable_collisions link1='base' link2='arm' reason='Adjacent'/>"
        "<group_state name='home' group='all'><joint name='j1' value='0.5'/>"
        "<joint name='root_joint' value='0 0 0 0 0 0 1'/></group_state></robot>"
    )
    robot = Robot.from_urdf(urdf, srdf=srdf)
    assert robot.model.referenceConfigurations["home"][0] == 0.5
