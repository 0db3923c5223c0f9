"""A robot's snapshot, checked against Pinocchio (used for every robot of example-robot-data).

:func:`check_robot_snapshot` renders the meshcat scene of ``Viewer(robot)`` (visual geometry
at the default posture, no floor or axes, a solid background) in headless Chromium and checks
it against Pinocchio, independently of the browser's mesh parsing:

* no JavaScript error (console errors, uncaught exceptions, failed scene commands) and no
  blocked request; the scene became ready and still;
* every drawn pixel (differing from the background) lies inside the projection of some
  geometry's bounding box (Pinocchio's placement of the geometry, coal's box of the mesh that
  Pinocchio loaded, the viewer's camera): a mesh drawn at the wrong place or scale fails;
* every geometry whose projected box covers at least ``MIN_BOX_PIXELS`` pixels has a drawn
  pixel inside that box: a geometry that is not drawn at all fails (whatever hides it would
  itself be drawn there).

JavaScript errors known to be harmless would be listed in ``ALLOWED_PAGE_ERRORS`` with their
reason; there are none. test_model_all_robots.py calls it on the robot it has just loaded and
checked (one load per robot); one browser per test process serves all robots; images are
200x150.
"""

from __future__ import annotations

import io
import math

import meshcat
import meshcat.path as mp
import numpy as np
import pinocchio as pin
from PIL import Image

from taskspace.model import Robot
from taskspace.viz import Viewer, render_html
from taskspace.viz.snapshots import SnapshotOptions
from taskspace.viz.viewer import CAMERA_FOV_DEG

SIZE = (200, 150)
BACKGROUND = (1.0, 0.0, 1.0)  # magenta: no robot of example-robot-data is drawn in it
MARGIN = 2  # pixels of antialiasing around a projected box
MIN_BOX_PIXELS = 30
ALLOWED_PAGE_ERRORS: dict[str, str] = {}  # message fragment -> why it is harmless


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


def _project(viewer: Viewer, points: np.ndarray) -> np.ndarray:
    """Pixel coordinates (x right, y down) of world points seen by the viewer's camera."""
    camera = viewer.camera
    assert camera is not None
    eye, target = np.array(camera.position), np.array(camera.target)
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = points - eye
    depth = rel @ forward
    assert np.all(depth > 0), "a geometry is behind the camera"
    focal = 0.5 * SIZE[1] / math.tan(math.radians(CAMERA_FOV_DEG) / 2)
    x = 0.5 * SIZE[0] + focal * (rel @ right) / depth
    y = 0.5 * SIZE[1] - focal * (rel @ up) / depth
    return np.stack([x, y], axis=1)


def _geometry_boxes(robot: Robot, viewer: Viewer) -> list[tuple[str, np.ndarray]]:
    """(name, projected corners) of every displayed geometry, placed by Pinocchio."""
    model, visual = robot.model, robot.visual_model
    if visual.ngeoms == 0:  # the viewer then shows the collision geometry
        visual = robot.collision_model
    data, vdata = model.createData(), visual.createData()
    pin.forwardKinematics(model, data, robot.q_default)
    pin.updateGeometryPlacements(model, data, visual, vdata)
    boxes = []
    for k, obj in enumerate(visual.geometryObjects):
        geometry = obj.geometry
        geometry.computeLocalAABB()
        lo = np.asarray(geometry.aabb_local.min_, float)
        hi = np.asarray(geometry.aabb_local.max_, float)
        corners = np.array(
            [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        placement = vdata.oMg[k]
        world = corners @ placement.rotation.T + placement.translation
        boxes.append((obj.name, _project(viewer, world)))
    return boxes


def _box_mask(corners: np.ndarray, margin: int) -> np.ndarray:
    mask = np.zeros((SIZE[1], SIZE[0]), dtype=bool)
    x0, y0 = np.floor(corners.min(axis=0)).astype(int) - margin
    x1, y1 = np.ceil(corners.max(axis=0)).astype(int) + margin
    mask[max(y0, 0) : max(y1 + 1, 0), max(x0, 0) : max(x1 + 1, 0)] = True
    return mask


def check_robot_snapshot(robot: Robot) -> None:
    """Render ``robot`` and check the image (see the module docstring)."""
    name = robot.name
    viewer = Viewer(robot, floor=False)
    background = meshcat.Visualizer.view_into(viewer.recorder, mp.Path(("Background",)))
    background.set_property("top_color", list(BACKGROUND))
    background.set_property("bottom_color", list(BACKGROUND))
    meshcat.Visualizer.view_into(viewer.recorder, mp.Path(("Axes",))).set_property("visible", False)
    allowed = SnapshotOptions(allowed_page_errors=tuple(ALLOWED_PAGE_ERRORS))
    result = render_html(viewer, size=SIZE, options=allowed)  # other page errors raise
    assert result.success, f"{name}: the scene did not become ready and still"
    errors = [e for e in result.page_errors if not any(a in e for a in ALLOWED_PAGE_ERRORS)]
    assert errors == [], f"{name}: JavaScript errors {errors}"
    assert result.blocked_requests == []

    rgb = _pixels(result.png)
    drawn = np.abs(rgb - np.array(BACKGROUND) * 255).sum(axis=-1) > 24
    boxes = _geometry_boxes(robot, viewer)
    inside = np.zeros_like(drawn)
    for _, corners in boxes:
        inside |= _box_mask(corners, MARGIN)
    outside = drawn & ~inside
    if not boxes:  # a model without any geometry (simple_humanoid_classical)
        assert drawn.sum() == 0, f"{name}: drawn pixels but no geometry"
        return
    assert drawn.sum() > 0, f"{name}: nothing drawn"
    assert outside.sum() == 0, (
        f"{name}: {outside.sum()} drawn pixels outside every geometry's projected box "
        f"(of {drawn.sum()} drawn), e.g. at (x, y) = {tuple(np.argwhere(outside)[0][::-1])}"
    )
    missing = [
        geometry
        for geometry, corners in boxes
        if (mask := _box_mask(corners, 0)).sum() >= MIN_BOX_PIXELS and not (drawn & mask).any()
    ]
    assert missing == [], f"{name}: geometries not drawn: {missing}"
