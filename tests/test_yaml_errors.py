"""Robot registry and MotionBenchMaker (MoveIt) YAML files: errors give the file and line.

Malformed YAML gives ``file:line:column``; a well-formed file with a bad entry gives
``file:line`` of that entry and what is valid; nothing raises a bare ``KeyError``,
``AttributeError``, ``TypeError`` or ``ValueError``, and nothing is silently misread (a name
given as a string instead of a list was split into characters, ``free_flyer: "no"`` read as
true).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from taskspace.errors import ModelLoadError, TaskspaceError
from taskspace.model.registry import read_registry, registry
from taskspace.planning.scene_loader import load_moveit_request, load_moveit_scene
from tests.conftest import load_robot

GOOD_ENTRY = "panda:\n  source: example-robot-data\n  name: panda\n"


def _write(tmp_path: Path, text: str, name: str = "file.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _raises_at(path: Path, line: int, match: str, load=read_registry) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ModelLoadError) as info:
        load(path)
    message = str(info.value)
    assert f"{path}:{line}" in message, message
    assert re.search(match, message), message


def test_shipped_registry_reads() -> None:
    assert {"panda", "ur5", "talos", "g1", "solo12"} <= set(registry())


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        # YAML syntax: file:line:column of the problem
        (GOOD_ENTRY + "ur5:\n  source: [urdf\n", 6, r":6:\d+: malformed YAML.*flow sequence"),
        (GOOD_ENTRY + "ur5: {source: urdf\n", 5, "malformed YAML"),
        # entries
        ("- panda\n", 1, "must be a mapping of robot names"),
        (GOOD_ENTRY + "ur5: 3\n", 4, "entry 'ur5' must be a mapping"),
        (GOOD_ENTRY + "ur5:\n  source: git\n", 5, "unknown source 'git'; valid sources are"),
        (GOOD_ENTRY + "ur5:\n  source: urdf\n", 5, "needs 'urdf'"),
        (
            GOOD_ENTRY + "ur5:\n  source: urdf\n  urdf: a.urdf\n  end_effector: [tool0]\n",
            7,
            "unknown key 'end_effector'; valid keys are: .*end_effectors",
        ),
        (
            GOOD_ENTRY + "ur5:\n  source: urdf\n  urdf: a.urdf\n  end_effectors: tool0\n",
            7,
            "'end_effectors' must be a list of names",
        ),
        (
            GOOD_ENTRY + "ur5:\n  source: urdf\n  urdf: a.urdf\n  free_flyer: 'no'\n",
            7,
            "free_flyer must be true or false",
        ),
        (
            GOOD_ENTRY + "ur5:\n  source: urdf\n  urdf: a.urdf\n  default_posture:\n"
            "    joints: {elbow: high}\n",
            8,
            "default_posture.joints must map joint names to numbers",
        ),
        (
            GOOD_ENTRY
            + "ur5:\n  source: urdf\n  urdf: a.urdf\n  default_posture: {bse: [0, 0, 1]}\n",
            7,
            "default_posture: unknown key 'bse'",
        ),
    ],
)
def test_registry_errors_give_the_line(tmp_path: Path, text: str, line: int, match: str) -> None:
    _raises_at(_write(tmp_path, text, "registry.yaml"), line, match)


def test_registry_file_problems(tmp_path: Path) -> None:
    with pytest.raises(ModelLoadError, match="robot registry not found"):
        read_registry(tmp_path / "missing.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00panda")
    with pytest.raises(ModelLoadError, match="cannot read robot registry"):
        read_registry(binary)
    specs = read_registry(_write(tmp_path, GOOD_ENTRY))
    assert specs["panda"].erd_name == "panda" and specs["panda"].end_effectors == ()


SCENE = """world:
  collision_objects:
    - id: table
      primitives:
        - type: box
          dimensions: [1, 1, 0.1]
      primitive_poses:
        - position: [0, 0, 0]
          orientation: [0, 0, 0, 1]
"""


@pytest.mark.parametrize(
    ("old", "new", "line", "match"),
    [
        ("[1, 1, 0.1]", "[1, one, 0.1]", 5, "dimensions must be real numbers"),
        ("[1, 1, 0.1]", "[1, 1, -0.1]", 5, "box needs 3 positive dimensions"),
        ("type: box", "type: torus", 5, "unsupported primitive type 'torus'"),
        ("[0, 0, 0, 1]", "[0, 0, 0]", 8, "pose needs position"),
        ("[0, 0, 0, 1]", "[0, 0, 0, 2]", 8, "quaternion has norm 2"),
        ("    - id: table\n", "    - 3\n    - id: table\n", 3, "collision object must be a map"),
        (
            "        - type: box\n          dimensions: [1, 1, 0.1]\n",
            "        - box\n",
            5,
            "a primitive must be a mapping",
        ),
        ("[1, 1, 0.1]", "[1, 1, 0.1\n", 8, r":8:\d+: malformed YAML"),
    ],
)
def test_scene_errors_give_the_line(
    tmp_path: Path, old: str, new: str, line: int, match: str
) -> None:
    assert len(load_moveit_scene(_write(tmp_path, SCENE))) == 1
    path = _write(tmp_path, SCENE.replace(old, new, 1), "bad.yaml")
    _raises_at(path, line, match, load_moveit_scene)


REQUEST = """start_state:
  joint_state:
    name: [panda_joint1, panda_joint2]
    position: [0.1, 0.2]
goal_constraints:
  - joint_constraints:
      - joint_name: panda_joint1
        position: 0.5
"""


@pytest.mark.parametrize(
    ("old", "new", "line", "match"),
    [
        ("position: [0.1, 0.2]", "position: [0.1]", 3, "2 names, 1 values"),
        ("position: [0.1, 0.2]", "position: [0.1, high]", 3, "must be a number"),
        ("position: 0.5", "position: [0.5j]", 7, "must be a number"),
        ("        position: 0.5\n", "", 7, "needs joint_name and position"),
        ("goal_constraints", "goal", 1, "expected start_state.joint_state"),
    ],
)
def test_request_errors_give_the_line(
    tmp_path: Path, old: str, new: str, line: int, match: str
) -> None:
    robot = load_robot("panda")
    request = load_moveit_request(robot, _write(tmp_path, REQUEST))
    assert request.goal[0] == pytest.approx(0.5) and request.start[1] == pytest.approx(0.2)
    path = _write(tmp_path, REQUEST.replace(old, new, 1), "bad.yaml")
    with pytest.raises(TaskspaceError) as info:
        load_moveit_request(robot, path)
    assert isinstance(info.value, ModelLoadError), repr(info.value)
    message = str(info.value)
    assert f"{path}:{line}" in message, message
    assert re.search(match, message), message
