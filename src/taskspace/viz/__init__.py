"""Visualization: meshcat scenes, static HTML, PNG snapshots and matplotlib helpers.

Names are imported lazily so that ``import taskspace.viz.plots_planning`` stays cheap (meshcat
and playwright are only imported when a viewer or a snapshot is used).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from taskspace._validation import require_extra

# meshcat, matplotlib and Pillow are the `viz` extra: one clear error when they are missing.
require_extra("viz", "taskspace.viz")

if TYPE_CHECKING:
    from taskspace.viz.env_viewer import MeshcatRender
    from taskspace.viz.figure_page import figure_page_html, save_figure_page
    from taskspace.viz.image_comparison import ImageComparison, compare_images
    from taskspace.viz.motion import save_robot_motion
    from taskspace.viz.plots import save_or_show, style_figure
    from taskspace.viz.scene_recorder import SceneRecorder
    from taskspace.viz.snapshots import (
        SnapshotError,
        SnapshotOptions,
        SnapshotResult,
        close_browser,
        render_html,
        snapshot,
    )
    from taskspace.viz.viewer import CameraPose, LiveViewerError, Viewer

_EXPORTS = {
    "CameraPose": "taskspace.viz.viewer",
    "ImageComparison": "taskspace.viz.image_comparison",
    "LiveViewerError": "taskspace.viz.viewer",
    "MeshcatRender": "taskspace.viz.env_viewer",
    "SceneRecorder": "taskspace.viz.scene_recorder",
    "SnapshotError": "taskspace.viz.snapshots",
    "SnapshotOptions": "taskspace.viz.snapshots",
    "SnapshotResult": "taskspace.viz.snapshots",
    "Viewer": "taskspace.viz.viewer",
    "close_browser": "taskspace.viz.snapshots",
    "compare_images": "taskspace.viz.image_comparison",
    "figure_page_html": "taskspace.viz.figure_page",
    "render_html": "taskspace.viz.snapshots",
    "save_figure_page": "taskspace.viz.figure_page",
    "save_or_show": "taskspace.viz.plots",
    "save_robot_motion": "taskspace.viz.motion",
    "snapshot": "taskspace.viz.snapshots",
    "style_figure": "taskspace.viz.plots",
}

__all__ = [
    "CameraPose",
    "ImageComparison",
    "LiveViewerError",
    "MeshcatRender",
    "SceneRecorder",
    "SnapshotError",
    "SnapshotOptions",
    "SnapshotResult",
    "Viewer",
    "close_browser",
    "compare_images",
    "figure_page_html",
    "render_html",
    "save_figure_page",
    "save_or_show",
    "save_robot_motion",
    "snapshot",
    "style_figure",
]


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'taskspace.viz' has no attribute {name!r}")
