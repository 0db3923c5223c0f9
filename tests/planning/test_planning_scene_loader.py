"""MoveIt / MotionBenchMaker YAML loader, against the numbers written in the files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from taskspace._validation import read_yaml
from taskspace.errors import ModelLoadError
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_ENV,
    MOTIONBENCHMAKER_SCENARIOS,
    load_moveit_request,
    load_moveit_scene,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from tests.planning._mbm import ROOT, SKIP_REASON

pytestmark = pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)

# The reference parse of the 350 scene files: libyaml's safe loader when PyYAML has it (same
# objects as yaml.SafeLoader on every file, about 5x faster), else the pure-Python one.
REFERENCE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def test_reads_every_scene_file() -> None:
    total = 0
    for scenario in MOTIONBENCHMAKER_SCENARIOS:
        problems = motionbenchmaker_problems(ROOT, scenario)
        assert len(problems) == 50
        for p in problems:
            raw = yaml.load(p.scene_path.read_text(), Loader=REFERENCE_LOADER)
            n_prims = sum(len(o["primitives"]) for o in raw["world"]["collision_objects"])
            assert len(p.obstacles) == n_prims
            total += n_prims
    assert total > 3000


def _marks(node: yaml.Node) -> list[tuple[str, str, int, int]]:
    """Kind, tag, line and column of every node of a document, depth first."""
    found = [(type(node).__name__, node.tag, node.start_mark.line, node.start_mark.column)]
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            found += _marks(key) + _marks(value)
    elif isinstance(node, yaml.SequenceNode):
        for value in node.value:
            found += _marks(value)
    return found


def test_read_yaml_gives_the_pure_python_parse() -> None:
    """read_yaml (libyaml's parser when PyYAML has it) against PyYAML's pure-Python loader.

    The same data and the same line of every node, on a scene and a request per scenario
    (test_reads_every_scene_file's reference uses libyaml too, for speed).
    """
    for scenario in MOTIONBENCHMAKER_SCENARIOS:
        folder = ROOT / f"{scenario}_panda"
        for path in (folder / "scene0001.yaml", folder / "request0001.yaml"):
            text = path.read_text()
            data, lines = read_yaml(path)
            assert data == yaml.load(text, Loader=yaml.SafeLoader), path
            assert _marks(lines._root) == _marks(yaml.compose(text, Loader=yaml.SafeLoader))


def test_box_pose_and_size_match_yaml() -> None:
    path = ROOT / "bookshelf_small_panda" / "scene0001.yaml"
    raw = yaml.safe_load(path.read_text())
    entry = next(o for o in raw["world"]["collision_objects"] if o["id"] == "shelf_bottom")
    pose = entry["primitive_poses"][0]
    obstacles = {o.name: o for o in load_moveit_scene(path)}
    box = obstacles["shelf_bottom"]
    np.testing.assert_allclose(box.placement.translation, pose["position"], atol=1e-12)
    x, y, z, w = pose["orientation"]
    # Rotation of a unit quaternion (w, x, y, z), written out.
    ref = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(box.placement.rotation, ref, atol=1e-9)
    np.testing.assert_allclose(2 * box.geometry.halfSide, entry["primitives"][0]["dimensions"])
    can = obstacles["Can1"]
    assert can.geometry.radius == pytest.approx(0.03)
    assert 2 * can.geometry.halfLength == pytest.approx(0.14)


def test_request_maps_joints_and_ignores_fingers() -> None:
    robot = motionbenchmaker_panda()
    req = load_moveit_request(robot, ROOT / "bookshelf_small_panda" / "request0001.yaml")
    np.testing.assert_allclose(req.start, [0, -0.785, 0, -2.356, 0, 1.571, 0.785])
    assert req.goal[0] == pytest.approx(1.48904932702624)
    assert req.ignored_joints == ["panda_finger_joint1", "panda_finger_joint2"]


def test_bad_files_raise(tmp_path: Path) -> None:
    with pytest.raises(ModelLoadError, match="not found"):
        load_moveit_scene(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "world:\n  collision_objects:\n    - id: x\n      primitives: [{type: torus, "
        "dimensions: [1]}]\n      primitive_poses: "
        "[{position: [0, 0, 0], orientation: [0, 0, 0, 1]}]\n"
    )
    with pytest.raises(ModelLoadError, match="unsupported primitive type 'torus'"):
        load_moveit_scene(bad)
    with pytest.raises(ModelLoadError, match="no scenario 'nope'"):
        motionbenchmaker_problems(ROOT, "nope")


def test_motionbenchmaker_dir_is_the_argument_or_the_environment_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert (ROOT / "cage_panda").is_dir()
    monkeypatch.setenv(MOTIONBENCHMAKER_ENV, str(tmp_path))
    assert motionbenchmaker_dir() == tmp_path
    assert motionbenchmaker_dir(ROOT) == ROOT  # the argument first
    monkeypatch.setenv(MOTIONBENCHMAKER_ENV, str(tmp_path / "missing"))
    with pytest.raises(ModelLoadError, match=f"{tmp_path / 'missing'} does not exist"):
        motionbenchmaker_dir()
    monkeypatch.delenv(MOTIONBENCHMAKER_ENV)
    monkeypatch.chdir(ROOT.parent)  # no search beside the working directory or elsewhere
    with pytest.raises(ModelLoadError, match=f"pass their directory or set {MOTIONBENCHMAKER_ENV}"):
        motionbenchmaker_dir()
    with pytest.raises(ModelLoadError, match="does not exist"):
        motionbenchmaker_dir(tmp_path / "nope")


def test_problems_read_their_files_once_apply_reads_none(tmp_path: Path) -> None:
    # the problems hold their parsed scene and request: applying one reads no file (the
    # planning suite times apply as part of a scene's set-up, its files read before)
    folder = tmp_path / "box_panda"
    folder.mkdir()
    for name in ("scene0003.yaml", "request0003.yaml"):
        (folder / name).write_bytes((ROOT / "box_panda" / name).read_bytes())
    problem = motionbenchmaker_problems(tmp_path, "box", [3])[0]
    robot = motionbenchmaker_panda()
    expected = load_moveit_request(robot, folder / "request0003.yaml")
    for name in ("scene0003.yaml", "request0003.yaml"):
        (folder / name).unlink()
    req = problem.apply(robot)
    np.testing.assert_array_equal(req.start, expected.start)
    np.testing.assert_array_equal(req.goal, expected.goal)
    assert req.ignored_joints == expected.ignored_joints
    assert req.group == expected.group != ""
    assert [o.name for o in robot.world] == [o.name for o in problem.obstacles]


def test_a_malformed_request_is_reported_when_the_problems_are_loaded(tmp_path: Path) -> None:
    folder = tmp_path / "box_panda"
    folder.mkdir()
    (folder / "scene0001.yaml").write_bytes((ROOT / "box_panda" / "scene0001.yaml").read_bytes())
    (folder / "request0001.yaml").write_text(
        "start_state:\n  joint_state:\n    name: [a, b]\n    position: [0.0]\n"
        "goal_constraints:\n  - joint_constraints: []\n"
    )
    with pytest.raises(ModelLoadError, match=r"request0001.yaml:3: start_state has 2 names, 1"):
        motionbenchmaker_problems(tmp_path, "box", [1])
