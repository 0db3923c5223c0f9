"""Robots of example-robot-data outside the registry render in a snapshot.

One robot of each kind that the registry does not cover (pendulum, mobile manipulator,
humanoid, hand, low-cost arm): the meshcat scene of ``Viewer(robot)`` renders in headless
Chromium with no JavaScript error and no blocked request, and the robot is drawn (the image
differs from the same scene without the robot in a sizeable part of its pixels).

Rendering all 71 loadable robots costs 2-45 s each on the shared test machine (the scene
export alone takes up to 12 s for anymal's textured meshes), far beyond the suite's budget;
test_model_all_robots.py loads every robot with its geometry.
"""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest
from PIL import Image

from taskspace.model import CollisionPruningOptions, Robot
from taskspace.viz import Viewer, render_html

pytestmark = [pytest.mark.slow, pytest.mark.snapshot, pytest.mark.xdist_group("browser")]

NAMES = ["double_pendulum", "tiago_no_hand", "alexander", "allegro_left_hand", "so100"]
SIZE = (320, 240)


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


@pytest.fixture(scope="module")
def empty_scene() -> np.ndarray:
    result = render_html(Viewer(), size=SIZE)
    assert result.success
    return _pixels(result.png)


@pytest.mark.parametrize("name", NAMES)
def test_robot_outside_the_registry_renders(name: str, empty_scene: np.ndarray) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load(name, collision_pruning=CollisionPruningOptions(enabled=False))
    result = render_html(Viewer(robot), size=SIZE)
    assert result.success
    assert result.page_errors == []
    assert result.blocked_requests == []
    changed = float((np.abs(_pixels(result.png) - empty_scene).sum(axis=-1) > 30).mean())
    assert changed > 0.01, f"only {changed:.2%} of the pixels show the robot"
