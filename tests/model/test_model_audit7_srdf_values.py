"""An SRDF posture with a non-finite joint value is a load error, not a posture at zero.

Pinocchio cannot read ``nan``, ``inf`` or ``1e400`` as a joint value: it prints "Could not
read joint config" and keeps the posture with 0 for that joint, so ``Robot.from_urdf(...,
srdf=...)`` used to load a reference posture silently different from the file.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from taskspace import ModelLoadError
from taskspace.model import Robot

URDF = """<robot name="r">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
</robot>
"""


def _srdf(value: str) -> str:
    return (
        "<robot name='r'>\n<group_state name='home' group='all'>\n"
        f"<joint name='j1' value='{value}'/>\n</group_state>\n</robot>"
    )


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_non_finite_posture_values_are_refused(tmp_path: Path, value: str) -> None:
    urdf = tmp_path / "r.urdf"
    urdf.write_text(URDF)
    srdf = tmp_path / "r.srdf"
    srdf.write_text(_srdf(value))
    # the reference: what Pinocchio makes of it (0, not the file's value)
    model = pin.buildModelFromUrdf(str(urdf))
    pin.loadReferenceConfigurationsFromXML(model, _srdf(value), False)
    assert np.asarray(model.referenceConfigurations["home"])[0] == 0.0
    message = f"group_state 'home': joint 'j1' value '{value}' is not finite"
    with pytest.raises(ModelLoadError, match=re.escape(f"{srdf}:3: {message}")):
        Robot.from_urdf(urdf, srdf=srdf)


def test_finite_posture_values_load(tmp_path: Path) -> None:
    urdf = tmp_path / "r.urdf"
    urdf.write_text(URDF)
    srdf = tmp_path / "r.srdf"
    srdf.write_text(_srdf("0.25"))
    robot = Robot.from_urdf(urdf, srdf=srdf)
    assert np.asarray(robot.model.referenceConfigurations["home"])[0] == 0.25
