"""Viewer scene construction (no browser): recorded commands, camera math, markers, errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import umsgpack

from taskspace.errors import InvalidInputError, ShapeError, UnknownNameError
from taskspace.viz import SceneRecorder, Viewer
from taskspace.viz.meshcat_geometry import parse_color, rotation_y_to, tube_mesh


def _commands(viewer: Viewer) -> list[dict]:
    return [umsgpack.unpackb(c) for c in viewer.recorder.packed_commands()]


def _transform(viewer: Viewer, path: str) -> np.ndarray:
    for c in _commands(viewer):
        if c["type"] == "set_transform" and c["path"] == path:
            return np.array(c["matrix"]).reshape(4, 4).T  # meshcat sends column-major
    raise AssertionError(f"no transform for {path}")


def test_recorder_keeps_last_object_and_deletes_subtrees():
    import meshcat
    import meshcat.geometry as mg

    rec = SceneRecorder()
    vis = meshcat.Visualizer(window=rec)
    vis["a/b"].set_object(mg.Box([1, 1, 1]))
    vis["a/b"].set_property("visible", False)
    vis["a/b"].set_object(mg.Sphere(0.5))  # replaces the box and clears the property
    vis["c/d"].set_object(mg.Box([1, 2, 3]))
    vis["c"].delete()
    cmds = [umsgpack.unpackb(c) for c in rec.packed_commands()]
    objects = [c for c in cmds if c["type"] == "set_object"]
    assert [c["path"] for c in objects] == ["/meshcat/a/b"]
    assert objects[0]["object"]["geometries"][0]["type"] == "SphereGeometry"
    assert not [c for c in cmds if c["type"] == "set_property" and c["path"] == "/meshcat/a/b"]
    # the readiness token is the last command
    assert cmds[-1] == {
        "type": "set_property",
        "path": "/taskspace_ready",
        "property": "taskspace_ready_token",
        "value": rec.token,
    }


def test_robot_geometry_placements_match_pinocchio(panda):
    q = panda.q_default.copy()
    q[1] += 0.3
    viewer = Viewer(panda, q)
    data = panda.model.createData()
    gdata = panda.visual_model.createData()
    pin.forwardKinematics(panda.model, data, q)
    pin.updateGeometryPlacements(panda.model, data, panda.visual_model, gdata)
    for k in (0, 4, 9):
        name = panda.visual_model.geometryObjects[k].name
        path = f"/meshcat/robot/visual/{k:03d}_{name}"
        np.testing.assert_allclose(_transform(viewer, path), gdata.oMg[k].homogeneous, atol=1e-12)


def test_camera_position_in_y_up_frame(panda):
    viewer = Viewer(panda)
    viewer.set_camera([2.0, 1.0, 1.5], [0.1, 0.2, 0.3])
    cmds = _commands(viewer)
    cam = [c for c in cmds if c["path"] == "/Cameras/default/rotated/<object>"]
    local = np.array(cam[-1]["value"])
    # meshcat's /Cameras/default/rotated node is a +90 deg rotation about x (y-up -> z-up)
    rx = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    np.testing.assert_allclose(rx @ local, np.array([2.0, 1.0, 1.5]) - [0.1, 0.2, 0.3])
    for root in ("/meshcat", "/Grid", "/Axes"):
        np.testing.assert_allclose(_transform(viewer, root)[:3, 3], [-0.1, -0.2, -0.3])


def test_frame_scene_fits_bounding_sphere(panda):
    viewer = Viewer(panda)
    pose = viewer.frame_scene(aspect=1.0)
    lo, hi = viewer.scene_bounds()
    radius = 1.05 * 0.5 * np.linalg.norm(hi - lo)
    distance = np.linalg.norm(np.subtract(pose.position, pose.target))
    assert distance == pytest.approx(radius / np.sin(np.radians(37.5)))
    np.testing.assert_allclose(pose.target, 0.5 * (lo + hi))


@pytest.mark.parametrize("direction", [[0, 1, 0], [1, 0, 0], [0, 0, -1], [0, -1, 0], [1, 2, 3]])
def test_rotation_y_to_is_a_rotation_onto_direction(direction):
    R = rotation_y_to(direction)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    np.testing.assert_allclose(R @ [0, 1, 0], d, atol=1e-12)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_tube_mesh_vertices_at_radius_from_axis():
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 1.0]])
    vertices, faces = tube_mesh(points, 0.05, sides=8)
    assert vertices.shape == (2 * 2 * 8, 3) and faces.shape == (2 * 2 * 8, 3)
    first = vertices[:16]  # segment along x: distance to the x axis is the radius
    np.testing.assert_allclose(np.hypot(first[:, 1], first[:, 2]), 0.05)
    assert faces.max() == vertices.shape[0] - 1


def test_animation_frames_and_interpolated_pose(panda):
    viewer = Viewer(panda)
    q0 = panda.q_default
    q1 = q0.copy()
    q1[0] += 1.0
    n = viewer.play(np.array([q0, q1]), dt=1.0, fps=10)
    assert n == 11
    anim = next(c for c in _commands(viewer) if c["type"] == "set_animation")
    clip = next(
        a for a in anim["animations"] if a["path"].endswith("robot/visual/008_panda_hand_0")
    )
    track = next(t for t in clip["clip"]["tracks"] if t["name"] == ".position")
    assert [k["time"] for k in track["keys"]] == list(range(11))
    # frame 5 is t = 0.5 s: joint 1 rotated by 0.5 rad
    q_half = q0.copy()
    q_half[0] += 0.5
    data = panda.model.createData()
    gdata = panda.visual_model.createData()
    pin.forwardKinematics(panda.model, data, q_half)
    pin.updateGeometryPlacements(panda.model, data, panda.visual_model, gdata)
    np.testing.assert_allclose(track["keys"][5]["value"], gdata.oMg[8].translation, atol=1e-9)


def test_markers_and_html_are_self_contained(panda):
    viewer = Viewer(panda)
    viewer.add_points("pts", np.zeros((3, 3)))
    viewer.add_path("line", [[0, 0, 0], [1, 0, 0]], radius=None)
    viewer.add_tree("tree", np.eye(3), [[0, 1], [1, 2]], node_size=0.01)
    viewer.add_force("f", [0, 0, 0], [0, 0, 100])
    viewer.add_com()
    viewer.delete("pts")
    paths = {c["path"] for c in _commands(viewer) if c["type"] == "set_object"}
    assert "/meshcat/markers/pts" not in paths
    assert {"/meshcat/markers/line", "/meshcat/markers/tree", "/meshcat/markers/f/shaft"} <= paths
    html = viewer.static_html()
    assert html.count("<script") == 3 and "<script src" not in html


def test_errors_have_clear_messages(panda):
    with pytest.raises(InvalidInputError, match="geometry must be 'visual' or 'collision'"):
        Viewer(panda, geometry="mesh")
    viewer = Viewer(panda)
    with pytest.raises(ShapeError, match=r"q must have shape \(7,\)"):
        viewer.display(np.zeros(6))
    with pytest.raises(InvalidInputError, match="at least 2 points"):
        viewer.add_path("p", [[0, 0, 0]])
    with pytest.raises(InvalidInputError, match=r"edges index nodes 0..1"):
        viewer.add_tree("t", np.zeros((2, 3)), [[0, 5]])
    with pytest.raises(UnknownNameError, match="unknown marker 'nope'"):
        viewer.delete("nope")
    with pytest.raises(InvalidInputError, match="RGB or RGBA"):
        parse_color([1, 2])
    with pytest.raises(InvalidInputError, match="no robot"):
        Viewer().display([0.0])
