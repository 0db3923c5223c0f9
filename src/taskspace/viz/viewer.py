"""``Viewer``: meshcat scenes of robots, frames, targets, paths, trees, obstacles and forces.

Every command goes to a :class:`~taskspace.viz.scene_recorder.SceneRecorder`, so a scene can be
exported as self-contained static HTML (:meth:`Viewer.static_html`) and rendered to PNG
(:meth:`Viewer.snapshot`) without any meshcat server. A live meshcat server (zmq + web
server) is started only with ``Viewer(..., live=True)``; it then receives the same commands.

Camera: meshcat 0.3.2 has no ``set_cam_target``/``set_cam_pos`` commands and its orbit
controls always look at the origin. :meth:`Viewer.set_camera` therefore translates the whole
scene (``/meshcat``, ``/Grid``, ``/Axes``) by ``-target`` and sets the ``position`` property of
``/Cameras/default/rotated/<object>``, which lives in three.js' y-up frame: a z-up offset
``(x, y, z)`` is written as ``(x, z, -y)``.

Thread safety: :class:`CameraPose` is an immutable value; a :class:`Viewer` is stateful (its scene,
recorder and live window) and not locked: use it from one thread at a time (its snapshots, from any
thread, run one at a time on the browser thread, see :mod:`taskspace.viz.snapshots`).
:class:`LiveViewerError` is an exception.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import quote, unquote

import numpy as np
import pinocchio as pin

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_matrix,
    as_vector,
    check_count,
    check_positive,
)
from taskspace.errors import InvalidInputError, TaskspaceError, UnknownNameError
from taskspace.model.robot import interpolate_configurations
from taskspace.model.world import World, as_se3
from taskspace.viz.meshcat_geometry import (
    geometry_aabb,
    geometry_commands,
    homogeneous,
    parse_color,
    phong,
    rgb_int,
    rotation_y_to,
    tube_mesh,
)
from taskspace.viz.scene_recorder import SceneRecorder

if TYPE_CHECKING:
    from taskspace.model.robot import Robot

logger = logging.getLogger(__name__)

CAMERA_FOV_DEG = 75.0
"""Vertical field of view of meshcat's default perspective camera [deg]."""

DEFAULT_VIEW_DIRECTION = (1.0, 0.75, 0.55)
"""Direction from the target to the camera used by automatic framing (z up)."""

_AXIS_COLORS = ((0.9, 0.1, 0.1, 1.0), (0.1, 0.75, 0.1, 1.0), (0.1, 0.25, 0.95, 1.0))
_MAX_FLOOR_LINES = 1000  # grid lines per axis of add_floor (each a 4-sided tube mesh)
MAX_COORDINATE = 1e30
"""Largest coordinate or length [m] a marker may have: WebGL stores vertices as float32
(largest 3.4e38), so larger values were drawn as inf (an arrow of length 1e300 had an infinite
shaft) without a word."""
MAX_ANIMATION_FRAMES = 100_000
"""Largest number of frames :meth:`Viewer.play` records (``fps=1e9`` recorded frames for ever)."""
ZMQ_CONNECT_TIMEOUT_S = 5.0
"""How long ``Viewer(zmq_url=...)`` waits for the meshcat server to answer."""


def _check_extent(values: Any, name: str) -> None:
    """Refuse coordinates or lengths beyond :data:`MAX_COORDINATE` (float32 in WebGL)."""
    top = float(np.max(np.abs(values))) if np.size(values) else 0.0
    if not top <= MAX_COORDINATE:
        raise InvalidInputError(
            f"{name} reaches {top:.3g} m; markers must stay within {MAX_COORDINATE:.0e} m "
            "(WebGL draws in float32, larger values become infinite)"
        )


def _check_meshcat_server(zmq_url: str) -> None:
    """Ask the meshcat server at ``zmq_url`` for its web URL, with a timeout.

    meshcat itself waits for the answer for ever (a wrong port hung ``Viewer(zmq_url=...)``).
    """
    import zmq

    if not isinstance(zmq_url, str) or not zmq_url:
        raise InvalidInputError(
            f"zmq_url must be a URL such as 'tcp://127.0.0.1:6000', got {zmq_url!r}"
        )
    socket: Any = zmq.Context.instance().socket(zmq.REQ)
    socket.setsockopt(zmq.LINGER, 0)
    try:
        try:
            socket.connect(zmq_url)
        except zmq.ZMQError as exc:
            raise InvalidInputError(
                f"zmq_url {zmq_url!r} is not a valid zmq address: {exc}"
            ) from None
        socket.send(b"url")
        if not socket.poll(int(ZMQ_CONNECT_TIMEOUT_S * 1000)):
            raise InvalidInputError(
                f"no meshcat server answered at {zmq_url} within {ZMQ_CONNECT_TIMEOUT_S:g} s: "
                "start one (meshcat-server) or use Viewer(..., live=True)"
            )
        socket.recv()
    finally:
        socket.close()


LIVE_COMMAND_TIMEOUT_S = 10.0
"""How long a command to a live meshcat server may wait for its answer before
:class:`LiveViewerError` (meshcat itself waited for ever on a server killed from outside)."""


class LiveViewerError(TaskspaceError):
    """The live meshcat server of a :class:`Viewer` stopped answering (killed, frozen)."""


class _LiveWindow:
    """A meshcat ``ViewerWindow`` whose commands fail with :class:`LiveViewerError`.

    A server killed from outside made the next command block for ever in meshcat's zmq
    ``recv``. A server process that has exited is reported at once; one that does not answer
    within :data:`LIVE_COMMAND_TIMEOUT_S` too. The zmq REQ socket is then unusable: the
    viewer stops forwarding (``Viewer.live`` is False, ``url`` says why) and keeps recording,
    so exports still work.
    """

    def __init__(self, window: Any) -> None:
        import zmq

        self.window = window
        self.error: str | None = None
        timeout_ms = max(1, int(LIVE_COMMAND_TIMEOUT_S * 1000))
        window.zmq_socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
        window.zmq_socket.setsockopt(zmq.SNDTIMEO, timeout_ms)
        window.zmq_socket.setsockopt(zmq.LINGER, 0)

    @property
    def server_proc(self) -> Any:
        return getattr(self.window, "server_proc", None)

    @property
    def web_url(self) -> str:
        return str(self.window.web_url)

    def open(self) -> None:
        self.window.open()

    def _fail(self, why: str) -> LiveViewerError:
        self.error = (
            f"the live meshcat server ({self.window.zmq_url}) {why}; the scene is still "
            "recorded (save_html / snapshot): call close(), or create a new "
            "Viewer(..., live=True)"
        )
        return LiveViewerError(self.error)

    def send(self, command: Any) -> None:
        import zmq

        if self.error is not None:
            return  # reported once; the recorder keeps the scene
        process = self.server_proc
        if process is not None and process.poll() is not None:
            raise self._fail(f"has exited (code {process.returncode})")
        try:
            self.window.send(command)
        except zmq.ZMQError as exc:  # zmq.Again: no answer within the timeout
            raise self._fail(
                f"did not answer within {LIVE_COMMAND_TIMEOUT_S:g} s ({exc})"
            ) from None


@dataclass(frozen=True, kw_only=True)
class CameraPose:
    """Camera placement in the world (z up).

    Attributes:
        position: camera position [m].
        target: point looked at [m].
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]


def _root_path(name: str) -> Any:
    import meshcat.path as mp

    return mp.Path((name,))


def _safe(name: str) -> str:
    """One meshcat path element per name, injectively (percent-encoding; "" -> "%").

    Replacing "/" and " " by "_" made "a/b", "a b" and "a_b" one node: the second marker
    silently replaced the first.
    """
    return quote(name, safe="") or "%"


def _unsafe(element: str) -> str:
    return "" if element == "%" else unquote(element)


class Viewer:
    """A meshcat scene recorder with robot display, markers, animations and exports.

    Args:
        robot: robot to display (optional; markers can be drawn without one).
        q: initial configuration (default posture if omitted).
        geometry: ``"visual"`` or ``"collision"`` geometry of the robot (a robot without
            visual geometry shows its collision geometry, with a logged warning).
        color: RGBA override for every robot geometry (default: the model colors).
        live: also start (or connect to) a meshcat server and send every command to it.
        zmq_url: URL of an existing meshcat server (implies ``live``).
        show_obstacles: draw the obstacles of ``robot.world``.
        floor: draw a floor grid at ``z = 0`` under the scene at export time. meshcat's own
            20 m grid is hidden: its long lines cross the camera's near plane, and
            software WebGL (SwiftShader, used for snapshots) then drops them.

    Example:
        >>> viewer = Viewer(Robot.load("panda"))            # doctest: +SKIP
        >>> viewer.add_frame("tcp", robot.frame_placement(q, "panda_hand_tcp"))  # doctest: +SKIP
        >>> viewer.save_html("scene.html"); png = viewer.snapshot("scene.png")  # doctest: +SKIP
    """

    def __init__(
        self,
        robot: Robot | None = None,
        q: Any = None,
        *,
        geometry: str = "visual",
        color: Any = None,
        live: bool = False,
        zmq_url: str | None = None,
        show_obstacles: bool = True,
        floor: bool = True,
    ) -> None:
        import meshcat

        from taskspace.model.robot import Robot

        if robot is not None and not isinstance(robot, Robot):
            raise InvalidInputError(
                f"robot must be a taskspace Robot (e.g. Robot.load('panda')) or None, got "
                f"{type(robot).__name__}"
            )
        if geometry not in ("visual", "collision"):
            raise InvalidInputError(f"geometry must be 'visual' or 'collision', got {geometry!r}")
        if (
            robot is not None
            and geometry == "visual"
            and robot._visual_model.ngeoms == 0
            and robot.robot_geometry_count > 0
        ):
            # simple_humanoid of example-robot-data: the viewer showed an empty scene
            logger.warning(
                "robot '%s' has no visual geometry: showing its collision geometry", robot.name
            )
            geometry = "collision"
        forward = None
        if zmq_url is not None:
            _check_meshcat_server(zmq_url)
        if live or zmq_url is not None:
            forward = _LiveWindow(meshcat.Visualizer(zmq_url=zmq_url).window)
        self._closed = False
        self.recorder = SceneRecorder(forward=forward)
        self.vis = meshcat.Visualizer(window=self.recorder)
        self.robot = robot
        self.geometry = geometry
        self._bounds: dict[str, FloatArray] = {}
        self._camera: CameraPose | None = None
        self._geom_paths: list[str] = []
        self._q: FloatArray | None = None
        self.floor = floor
        self._floor_drawn = False
        meshcat.Visualizer.view_into(self.recorder, _root_path("Grid")).set_property(
            "visible", False
        )
        if robot is not None:
            self._load_robot(robot, color)
            self.display(robot.q_default if q is None else q)
            if show_obstacles and len(robot.world):
                self.add_obstacles()

    # ------------------------------------------------------------------ robot
    @property
    def geometry_model(self) -> pin.GeometryModel:
        """The displayed geometry model: ``robot.visual_model`` or ``robot.collision_model``.

        The robot's read-only copy (edit the robot through
        :meth:`~taskspace.model.Robot.edit_collision_model`).
        """
        robot = self._require_robot()
        return robot.visual_model if self.geometry == "visual" else robot.collision_model

    def _geometry_model(self) -> pin.GeometryModel:
        robot = self._require_robot()
        return robot._visual_model if self.geometry == "visual" else robot._collision_model

    def _require_robot(self) -> Robot:
        if self.robot is None:
            raise InvalidInputError("this viewer has no robot: create it with Viewer(robot)")
        return self.robot

    def _robot_geometries(self) -> list[pin.GeometryObject]:
        robot = self._require_robot()
        objs = list(self._geometry_model().geometryObjects)
        if self.geometry == "collision":
            objs = objs[: robot.robot_geometry_count]
        return objs

    def _load_robot(self, robot: Robot, color: Any) -> None:
        import meshcat.commands as mc

        base = f"robot/{self.geometry}"
        self._geom_paths = []
        for k, obj in enumerate(self._robot_geometries()):
            node = f"{base}/{k:03d}_{_safe(obj.name)}"
            commands, offset, scaled = geometry_commands(f"/meshcat/{node}/shape", obj, color=color)
            for command in commands:
                self.recorder.send(command)
            if scaled:
                offset = offset @ np.diag(np.append(np.asarray(obj.meshScale, float), 1.0))
            if commands and not np.allclose(offset, np.eye(4)):
                self.recorder.send(mc.SetTransform(offset, self.vis[f"{node}/shape"].path))
            self._geom_paths.append(node)

    def _placements(self, q: FloatArray) -> list[pin.SE3]:
        robot = self._require_robot()
        data = robot._model.createData()
        gmodel = self._geometry_model()
        gdata = gmodel.createData()
        pin.forwardKinematics(robot._model, data, q)
        pin.updateGeometryPlacements(robot._model, data, gmodel, gdata)
        return [gdata.oMg[k].copy() for k in range(len(self._geom_paths))]

    def display(self, q: Any) -> None:
        """Place the robot at configuration ``q`` (size nq).

        Raises:
            ShapeError, NotFiniteError: malformed ``q``.
        """
        robot = self._require_robot()
        qa = robot.check_configuration(q)
        placements = self._placements(qa)
        corners = []
        for node, obj, placement in zip(self._geom_paths, self._robot_geometries(), placements):
            self.vis[node].set_transform(placement.homogeneous)
            box = geometry_aabb(obj.geometry, placement)
            corners.append(box if box is not None else placement.translation[None, :])
        self._q = qa
        if corners:
            self._bounds["__robot__"] = np.vstack(corners)

    @property
    def q(self) -> FloatArray:
        """The configuration last displayed."""
        if self._q is None:
            raise InvalidInputError("no configuration displayed yet: call display(q)")
        return self._q

    # ------------------------------------------------------------------ markers
    def _marker(self, name: str) -> str:
        if not isinstance(name, str) or not name:
            raise InvalidInputError(f"marker name must be a non-empty string, got {name!r}")
        return f"markers/{_safe(name)}"

    def add_frame(
        self, name: str, pose: Any, scale: float = 0.1, radius: float | None = None
    ) -> None:
        """Draw a triad (x red, y green, z blue) at ``pose``.

        Args:
            name: marker name (replaces a marker of the same name).
            pose: ``pin.SE3``, 4x4 matrix, ``[x, y, z]`` or ``[x, y, z, qx, qy, qz, qw]``.
            scale: axis length [m].
            radius: axis radius [m] (default ``scale / 25``).
        """
        import meshcat.geometry as mg

        placement = as_se3(pose if isinstance(pose, pin.SE3) else as_float_array(pose, "pose"))
        length = check_positive(scale, "scale")
        r = length / 25.0 if radius is None else check_positive(radius, "radius")
        _check_extent([*placement.translation, length, r], "the frame (position, scale, radius)")
        node = self._marker(name)
        self.vis[node].delete()
        for axis, label in enumerate("xyz"):
            direction = np.eye(3)[axis]
            child = self.vis[f"{node}/{label}"]
            child.set_object(mg.Cylinder(length, r), phong(_AXIS_COLORS[axis]))
            child.set_transform(homogeneous(rotation_y_to(direction), direction * length / 2))
        self.vis[node].set_transform(placement.homogeneous)
        self._bounds[node] = placement.translation + length * np.vstack([np.zeros(3), np.eye(3)])

    def add_target(
        self, name: str, pose: Any, scale: float = 0.1, color: Any = (1.0, 0.55, 0.0, 0.5)
    ) -> None:
        """Draw a target: a triad at ``pose`` inside a translucent sphere of radius ``scale/3``."""
        import meshcat.geometry as mg

        self.add_frame(name, pose, scale)
        node = self._marker(name)
        self.vis[f"{node}/ball"].set_object(mg.Sphere(scale / 3.0), phong(parse_color(color)))

    def add_robot_frames(self, frames: Sequence[str] | None = None, scale: float = 0.1) -> None:
        """Draw triads at robot frames for the displayed configuration (default: end-effectors)."""
        robot = self._require_robot()
        names = list(robot.end_effectors) if frames is None else list(frames)
        for frame in names:
            self.add_frame(f"frame_{frame}", robot.frame_placement(self.q, frame), scale)

    def add_points(
        self, name: str, points: Any, color: Any = (0.95, 0.8, 0.1), size: float = 0.02
    ) -> None:
        """Draw points ``(N, 3)`` [m] as squares of side ``size`` [m]."""
        import meshcat.geometry as mg

        p = as_matrix(points, (None, 3), "points")
        _check_extent([*p.ravel(), check_positive(size, "size")], "points (and size)")
        node = self._marker(name)
        material = mg.PointsMaterial(
            size=check_positive(size, "size"), color=rgb_int(parse_color(color))
        )
        self.vis[node].set_object(mg.PointsGeometry(p.T.astype(np.float32)), material)
        self._bounds[node] = p

    def add_path(
        self,
        name: str,
        points: Any,
        color: Any = (0.95, 0.2, 0.6),
        radius: float | None = 0.005,
    ) -> None:
        """Draw a polyline through ``points (N, 3)`` [m] (end-effector traces, planned paths).

        Args:
            name: marker name.
            points: the vertices, ``N >= 2``.
            color: RGB(A) in [0, 1].
            radius: tube radius [m] (WebGL lines are 1 pixel wide); ``None`` draws a line.
        """
        import meshcat.geometry as mg

        p = as_matrix(points, (None, 3), "points")
        if p.shape[0] < 2:
            raise InvalidInputError(f"a path needs at least 2 points, got {p.shape[0]}")
        r = None if radius is None else check_positive(radius, "radius")
        _check_extent([*p.ravel(), r or 0.0], "path (points, radius)")
        node = self._marker(name)
        rgba = parse_color(color)
        if r is None:
            line = mg.Line(
                mg.PointsGeometry(p.T.astype(np.float32)),
                mg.LineBasicMaterial(color=rgb_int(rgba)),
            )
            self.vis[node].set_object(line)
        else:
            vertices, faces = tube_mesh(p, r)
            self.vis[node].set_object(mg.TriangularMeshGeometry(vertices, faces), phong(rgba))
        self._bounds[node] = p

    def add_frame_trace(
        self,
        name: str,
        configurations: Any,
        frame: str | None = None,
        color: Any = (0.95, 0.2, 0.6),
        radius: float | None = 0.005,
    ) -> FloatArray:
        """Draw the trace of a robot frame (default: first end-effector) along configurations.

        Returns:
            The traced positions ``(N, 3)`` [m].
        """
        robot = self._require_robot()
        qs = as_matrix(configurations, (None, robot.nq), "configurations")
        frame_name = frame if frame is not None else robot.end_effectors[0]
        fid = robot.frame_id(frame_name)
        data = robot._model.createData()
        points = np.empty((qs.shape[0], 3))
        for i, q in enumerate(qs):
            pin.framesForwardKinematics(robot._model, data, q)
            points[i] = data.oMf[fid].translation
        self.add_path(name, points, color, radius)
        return points

    def add_segments(
        self, name: str, segments: Any, color: Any = (0.2, 0.2, 0.2), radius: float | None = None
    ) -> None:
        """Draw line segments ``(E, 2, 3)`` [m] (trees, roadmaps, visibility graphs).

        Args:
            name: marker name.
            segments: segment end points.
            color: RGB(A) in [0, 1].
            radius: draw each segment as a tube of this radius [m] instead of a 1-px line.
        """
        import meshcat.geometry as mg

        s = as_float_array(segments, "segments")  # refuses complex (no silent truncation)
        if s.ndim != 3 or s.shape[1:] != (2, 3) or s.shape[0] == 0:
            raise InvalidInputError(
                f"segments must have shape (E, 2, 3) with E >= 1, got {s.shape}"
            )
        if not np.all(np.isfinite(s)):
            raise InvalidInputError("segments have non-finite entries")
        _check_extent(
            [*s.ravel(), 0.0 if radius is None else check_positive(radius, "radius")],
            "segments (radius)",
        )
        node = self._marker(name)
        rgba = parse_color(color)
        flat = s.reshape(-1, 3)
        if radius is None:
            obj = mg.LineSegments(
                mg.PointsGeometry(flat.T.astype(np.float32)),
                mg.LineBasicMaterial(color=rgb_int(rgba)),
            )
            self.vis[node].set_object(obj)
        else:
            r = check_positive(radius, "radius")
            parts = [tube_mesh(seg, r, sides=6) for seg in s]
            offsets = np.cumsum([0] + [v.shape[0] for v, _ in parts[:-1]])
            vertices = np.vstack([v for v, _ in parts])
            faces = np.vstack([f + o for (_, f), o in zip(parts, offsets)])
            self.vis[node].set_object(mg.TriangularMeshGeometry(vertices, faces), phong(rgba))
        self._bounds[node] = flat

    def add_tree(
        self,
        name: str,
        nodes: Any,
        edges: Any,
        color: Any = (0.2, 0.2, 0.2),
        radius: float | None = None,
        node_size: float | None = None,
    ) -> None:
        """Draw a planning tree or roadmap: node positions ``(N, 3)`` [m], edges ``(E, 2)``.

        Edges are index pairs into ``nodes`` (for a tree, ``(i, parent[i])``).
        """
        p = as_matrix(nodes, (None, 3), "nodes")
        try:
            raw = np.asarray(edges)
            e = raw.astype(int).reshape(-1, 2)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"edges must be integer pairs (E, 2): {exc}") from exc
        if raw.dtype.kind not in "iub" and not np.array_equal(raw.reshape(-1, 2), e):
            # [[0.5, 1.7]] was truncated to the edge (0, 1)
            raise InvalidInputError(f"edges must be integer node indices, got {edges!r}")
        if e.size and (e.min() < 0 or e.max() >= p.shape[0]):
            raise InvalidInputError(
                f"edges index nodes 0..{p.shape[0] - 1}, got indices in [{e.min()}, {e.max()}]"
            )
        if e.shape[0]:
            self.add_segments(name, p[e], color, radius)
        if node_size is not None:
            self.add_points(f"{name}_nodes", p, color, node_size)

    def add_arrow(
        self,
        name: str,
        origin: Any,
        vector: Any,
        color: Any = (0.9, 0.15, 0.1),
        radius: float = 0.01,
        on_top: bool = False,
    ) -> None:
        """Draw an arrow from ``origin`` along ``vector`` [m] (shaft + cone head).

        ``on_top`` draws it over the robot (visible inside a foot or a hand).
        """
        import meshcat.geometry as mg

        from taskspace.viz.meshcat_geometry import ConeGeometry

        o = as_vector(origin, 3, "origin")
        v = as_vector(vector, 3, "vector")
        _check_extent([*o, *v, check_positive(radius, "radius")], "arrow (origin, vector, radius)")
        length = float(np.linalg.norm(v))
        node = self._marker(name)
        self.vis[node].delete()
        if length < 1e-9:
            self._bounds.pop(node, None)
            return
        r = check_positive(radius, "radius")
        head = min(0.3 * length, 5.0 * r)
        shaft = length - head
        material = phong(parse_color(color), on_top=on_top)
        self.vis[f"{node}/shaft"].set_object(mg.Cylinder(shaft, r), material)
        self.vis[f"{node}/shaft"].set_transform(homogeneous(translation=[0.0, shaft / 2, 0.0]))
        self.vis[f"{node}/head"].set_object(ConeGeometry(head, 2.2 * r), material)
        self.vis[f"{node}/head"].set_transform(
            homogeneous(translation=[0.0, shaft + head / 2, 0.0])
        )
        self.vis[node].set_transform(homogeneous(rotation_y_to(v), o))
        self._bounds[node] = np.vstack([o, o + v])

    def add_force(
        self,
        name: str,
        point: Any,
        force: Any,
        scale: float = 0.002,
        color: Any = (0.9, 0.15, 0.1),
        radius: float = 0.012,
        on_top: bool = True,
    ) -> None:
        """Draw a contact force [N] applied at ``point`` [m] as an arrow of ``scale`` [m/N].

        The arrow starts at the contact point; by default it is drawn over the robot.
        """
        f = as_vector(force, 3, "force")
        self.add_arrow(name, point, check_positive(scale, "scale") * f, color, radius, on_top)

    def add_com(
        self,
        name: str = "com",
        q: Any = None,
        radius: float = 0.04,
        color: Any = (0.95, 0.75, 0.05),
        on_top: bool = True,
    ) -> FloatArray:
        """Draw the robot's center of mass (sphere) and its ground projection (line to z=0).

        ``com = sum_i m_i c_i / sum_i m_i`` (Pinocchio ``centerOfMass``); by default drawn over
        the robot, since it usually lies inside the body.

        Returns:
            The center of mass [m].
        """
        import meshcat.geometry as mg

        robot = self._require_robot()
        qa = self.q if q is None else robot.check_configuration(q)
        com = np.asarray(pin.centerOfMass(robot._model, robot._model.createData(), qa), dtype=float)
        node = self._marker(name)
        material = phong(color, on_top=on_top)
        _check_extent(check_positive(radius, "radius"), "radius")
        self.vis[f"{node}/ball"].set_object(mg.Sphere(check_positive(radius, "radius")), material)
        self.vis[f"{node}/ball"].set_transform(homogeneous(translation=com))
        ground = np.array([com, [com[0], com[1], 0.0]])
        vertices, faces = tube_mesh(ground, radius / 6.0)
        self.vis[f"{node}/drop"].set_object(mg.TriangularMeshGeometry(vertices, faces), material)
        self._bounds[node] = com[None, :]
        return com

    def add_obstacles(self, world: World | None = None, color: Any = None) -> None:
        """Draw the obstacles of ``world`` (default: the robot's world)."""
        if world is None:
            world = self._require_robot().world
        for obstacle in world:
            node = f"obstacles/{_safe(obstacle.name)}"
            geom = pin.GeometryObject(obstacle.name, 0, 0, pin.SE3.Identity(), obstacle.geometry)
            if obstacle.mesh_path:
                geom.meshPath = obstacle.mesh_path
            geom.meshColor = np.asarray(obstacle.color, dtype=float)
            commands, offset, _ = geometry_commands(f"/meshcat/{node}/shape", geom, color)
            for command in commands:
                self.recorder.send(command)
            if not np.allclose(offset, np.eye(4)):
                self.vis[f"{node}/shape"].set_transform(offset)
            self.vis[node].set_transform(obstacle.placement.homogeneous)
            box = geometry_aabb(obstacle.geometry, obstacle.placement)
            self._bounds[node] = box if box is not None else obstacle.placement.translation[None]

    def delete(self, name: str) -> None:
        """Remove a marker (or ``"obstacles"``) from the scene."""
        node = name if name == "obstacles" else self._marker(name)
        # the node and what lies under it ("tcp" must not take "tcp2" or "tcp_nodes" along)
        known = {k for k in self._bounds if k == node or k.startswith(node + "/")}
        if not known and name != "obstacles":
            valid = list(
                dict.fromkeys(
                    _unsafe(k.removeprefix("markers/").split("/")[0])
                    for k in self._bounds
                    if k.startswith("markers/")
                )
            )
            raise UnknownNameError("marker", name, valid)
        self.vis[node].delete()
        for k in known:
            del self._bounds[k]

    # ------------------------------------------------------------------ animation
    def play(
        self,
        configurations: Any,
        dt: float,
        *,
        fps: float = 30.0,
        autoplay: bool = True,
        repetitions: int = 1,
    ) -> int:
        """Animate the robot through ``configurations (N, nq)`` sampled every ``dt`` [s].

        The trajectory is resampled at ``fps`` frames per second (configurations interpolated
        on the configuration manifold, ``pin.interpolate``) and stored as a meshcat animation:
        the exported HTML has a time slider and play controls. The static scene shows the
        first configuration.

        Returns:
            The number of animation frames.
        """
        from meshcat.animation import Animation

        robot = self._require_robot()
        qs = as_matrix(configurations, (None, robot.nq), "configurations")
        step = check_positive(dt, "dt")
        rate = check_positive(fps, "fps")
        loops = check_count(repetitions, "repetitions", minimum=1)
        if not isinstance(autoplay, (bool, np.bool_)):
            raise InvalidInputError(f"autoplay must be True or False, got {autoplay!r}")
        if qs.shape[0] < 1:
            raise InvalidInputError("play needs at least one configuration")
        duration = (qs.shape[0] - 1) * step
        frames = duration * rate
        if not frames < MAX_ANIMATION_FRAMES:
            raise InvalidInputError(
                f"{qs.shape[0]} configurations every {step:g} s at {rate:g} fps make "
                f"{frames:.3g} animation frames (at most {MAX_ANIMATION_FRAMES}): lower fps"
            )
        for i, q in enumerate(qs):
            robot.check_configuration(q, f"configurations[{i}]")
        n_frames = max(1, math.floor(frames + 1e-9) + 1)
        self.display(qs[0])
        animation = Animation(default_framerate=rate)
        for frame in range(n_frames):
            s = min(frame / rate / step, qs.shape[0] - 1.0)
            i = min(math.floor(s), qs.shape[0] - 2) if qs.shape[0] > 1 else 0
            alpha = s - i
            if qs.shape[0] > 1:
                # q_i (+) alpha (q_i+1 (-) q_i), the robot's interpolation (pin.interpolate
                # stays at q_i on a continuous joint between opposite angles)
                q = interpolate_configurations(
                    robot._model, qs[i], qs[i + 1], np.array([alpha]), robot._continuous
                )[0]
            else:
                q = qs[0]
            with animation.at_frame(self.vis, frame) as anim_frame:
                for node, placement in zip(self._geom_paths, self._placements(q)):
                    anim_frame[node].set_transform(placement.homogeneous)
        self.vis.set_animation(animation, play=bool(autoplay), repetitions=loops)
        return n_frames

    # ------------------------------------------------------------------ camera
    def scene_bounds(self) -> tuple[FloatArray, FloatArray]:
        """Axis-aligned bounds ``(lower, upper)`` [m] of everything drawn so far."""
        if not self._bounds:
            return np.full(3, -0.5), np.full(3, 0.5)
        pts = np.vstack(list(self._bounds.values()))
        return pts.min(axis=0), pts.max(axis=0)

    def set_camera(self, position: Any, target: Any = (0.0, 0.0, 0.0)) -> CameraPose:
        """Place the camera at ``position`` looking at ``target`` (world, z up) [m].

        The scene is translated by ``-target`` so that meshcat's orbit target (the origin)
        coincides with ``target``; the camera offset ``d = position - target`` is written in
        three.js' y-up frame as ``(d_x, d_z, -d_y)``.
        """
        import meshcat
        import meshcat.path as mp

        p = as_vector(position, 3, "position")
        t = as_vector(target, 3, "target")
        _check_extent([*p, *t], "camera position and target")
        d = p - t
        if float(np.linalg.norm(d)) < 1e-6:
            raise InvalidInputError("camera position and target must differ")
        shift = homogeneous(translation=-t)
        for root in ("meshcat", "Grid", "Axes"):
            meshcat.Visualizer.view_into(self.recorder, mp.Path((root,))).set_transform(shift)
        camera = meshcat.Visualizer.view_into(
            self.recorder, mp.Path(("Cameras", "default", "rotated", "<object>"))
        )
        camera.set_property("position", [float(d[0]), float(d[2]), float(-d[1])])
        self._camera = CameraPose(
            position=(float(p[0]), float(p[1]), float(p[2])),
            target=(float(t[0]), float(t[1]), float(t[2])),
        )
        return self._camera

    def frame_scene(
        self, direction: Any = DEFAULT_VIEW_DIRECTION, margin: float = 1.05, aspect: float = 4 / 3
    ) -> CameraPose:
        """Point the camera at the center of the scene bounds from ``direction``.

        The distance ``r / sin(fov / 2)`` (with ``r`` the bounding-sphere radius times
        ``margin`` and ``fov`` the smaller of the vertical and horizontal fields of view) makes
        the bounding sphere fit in the image.
        """
        lo, hi = self.scene_bounds()
        center = 0.5 * (lo + hi)
        radius = max(0.5 * float(np.linalg.norm(hi - lo)), 0.1) * check_positive(margin, "margin")
        fov_v = math.radians(CAMERA_FOV_DEG)
        fov_h = 2.0 * math.atan(math.tan(fov_v / 2) * check_positive(aspect, "aspect"))
        half = 0.5 * min(fov_v, fov_h)
        d = as_vector(direction, 3, "direction")
        norm = float(np.linalg.norm(d))
        if norm < 1e-9:
            raise InvalidInputError("direction must be non-zero")
        distance = radius / math.sin(half)
        pose = self.set_camera(center + distance * d / norm, center)
        return pose

    @property
    def camera(self) -> CameraPose | None:
        """The camera pose set by :meth:`set_camera` or :meth:`frame_scene` (or ``None``)."""
        return self._camera

    def add_floor(
        self,
        extent: tuple[float, float, float, float] | None = None,
        spacing: float = 0.25,
        color: Any = (0.55, 0.55, 0.6),
    ) -> None:
        """Draw a floor grid at ``z = 0`` made of thin triangle strips.

        Args:
            extent: ``(x_min, y_min, x_max, y_max)`` [m]; default: the scene bounds plus
                0.5 m, rounded to ``spacing``.
            spacing: distance between grid lines [m].
            color: RGB(A) in [0, 1].
        """
        import meshcat.geometry as mg

        step = check_positive(spacing, "spacing")
        if extent is None:
            lo, hi = self.scene_bounds()
            x0, y0 = np.floor((lo[:2] - 0.5) / step) * step
            x1, y1 = np.ceil((hi[:2] + 0.5) / step) * step
        else:
            x0, y0, x1, y1 = (float(e) for e in as_vector(extent, 4, "extent"))
            if not (x1 > x0 and y1 > y0):
                raise InvalidInputError(f"extent must have x_max > x_min, y_max > y_min: {extent}")
        span = max(x1 - x0, y1 - y0)
        if not math.isfinite(span):
            raise InvalidInputError(
                f"the floor extent ({x0:g}, {y0:g}, {x1:g}, {y1:g}) is not finite: pass a finite "
                "extent (the default follows the scene bounds)"
            )
        if span / step > _MAX_FLOOR_LINES:
            # ~1e6 m at 0.25 m spacing was 8 million tubes per axis (the viewer hung)
            if extent is not None:
                raise InvalidInputError(
                    f"a floor of extent {span:g} m with spacing {step:g} m has more than "
                    f"{_MAX_FLOOR_LINES} lines per axis: pass a larger spacing or a smaller extent"
                )
            step = span / _MAX_FLOOR_LINES  # automatic extent (far markers): coarser grid
        xs = np.arange(x0, x1 + 0.5 * step, step)
        ys = np.arange(y0, y1 + 0.5 * step, step)
        segments = [((x, y0, 0.0), (x, y1, 0.0)) for x in xs]
        segments += [((x0, y, 0.0), (x1, y, 0.0)) for y in ys]
        parts = [tube_mesh(np.array(seg), 0.002, sides=4) for seg in segments]
        offsets = np.cumsum([0] + [v.shape[0] for v, _ in parts[:-1]])
        vertices = np.vstack([v for v, _ in parts])
        faces = np.vstack([f + o for (_, f), o in zip(parts, offsets)])
        material = mg.MeshBasicMaterial(color=rgb_int(parse_color(color)))
        self.vis["floor"].set_object(mg.TriangularMeshGeometry(vertices, faces), material)
        self._floor_drawn = True

    # ------------------------------------------------------------------ export
    def static_html(
        self, title: str = "taskspace scene", *, compress: bool = True, level: int = 6
    ) -> str:
        """Self-contained HTML of the scene (no network access needed to view it).

        If no camera was set, the scene is framed automatically first; the floor grid is
        drawn if enabled and not drawn yet. ``compress`` stores each mesh once, compressed
        with zlib ``level`` (see :meth:`SceneRecorder.static_html`).
        """
        if not isinstance(title, str):
            raise InvalidInputError(f"title must be a string, got {type(title).__name__}")
        self._prepare_export()
        return self.recorder.static_html(title=title, compress=compress, level=level)

    def _prepare_export(self, aspect: float = 4 / 3) -> None:
        if self.floor and not self._floor_drawn:
            self.add_floor()
        if self._camera is None:
            self.frame_scene(aspect=aspect)

    def save_html(
        self, path: str | Path, title: str = "taskspace scene", *, compress: bool = True
    ) -> Path:
        """Write :meth:`static_html` to ``path`` (parent directories are created)."""
        from taskspace.viz.snapshots import check_output_path, write_output

        check_output_path(path)  # before the seconds of exporting
        return write_output(path, self.static_html(title, compress=compress).encode("utf-8"))

    def snapshot(self, path: str | Path | None = None, size: tuple[int, int] = (640, 480)) -> bytes:
        """Render the scene to PNG in headless Chromium (see :func:`taskspace.viz.snapshot`)."""
        from taskspace.viz.snapshots import check_png_path, check_size, snapshot

        width, height = check_size(size)
        if path is not None:
            check_png_path(path)  # before the seconds of rendering
        self._prepare_export(aspect=width / height)
        return snapshot(self, path, size)

    # ------------------------------------------------------------------ live viewer
    @property
    def live(self) -> bool:
        """Whether a live meshcat server receives the commands.

        A live server that stops answering (killed, frozen) makes the next command raise
        :class:`LiveViewerError` within :data:`LIVE_COMMAND_TIMEOUT_S`; the viewer is then
        no longer live and keeps recording the scene.
        """
        forward = self.recorder.forward
        return forward is not None and getattr(forward, "error", None) is None

    @property
    def url(self) -> str:
        """URL of the live meshcat server (open it in a browser)."""
        if not self.live:
            raise InvalidInputError(self._not_live())
        return str(self.recorder.forward.web_url)  # type: ignore[union-attr]

    def open(self) -> None:
        """Open the live viewer in a web browser."""
        if not self.live:
            raise InvalidInputError(self._not_live())
        self.recorder.forward.open()  # type: ignore[union-attr]

    def _not_live(self) -> str:
        error = getattr(self.recorder.forward, "error", None)
        if error is not None:
            return f"this viewer is not live any more: {error}"
        if self._closed:
            return (
                "this viewer is not live any more: close() stopped its meshcat server; the "
                "recorded scene remains (save_html / snapshot), or create a new "
                "Viewer(..., live=True)"
            )
        return "this viewer is not live: create it with Viewer(..., live=True)"

    def wait_until_interrupted(self, timeout: float | None = None) -> bool:
        """Keep the live meshcat server up until Ctrl-C (or ``timeout`` [s]), then stop it.

        Returns:
            ``True`` when Ctrl-C ended the wait, ``False`` when the timeout did.
        """
        if not self.live:
            raise InvalidInputError(self._not_live())
        end = None if timeout is None else time.monotonic() + check_positive(timeout, "timeout")
        interrupted = False
        try:
            while end is None or time.monotonic() < end:
                left = 0.25 if end is None else min(0.25, max(end - time.monotonic(), 0.0))
                time.sleep(left)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            self.close()
        return interrupted

    def close(self) -> None:
        """Stop the live meshcat server this viewer started (the recorded scene stays)."""
        forward, self.recorder.forward = self.recorder.forward, None
        self._closed = self._closed or forward is not None
        process = getattr(forward, "server_proc", None)
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=5)
            except Exception:  # pragma: no cover (a server that ignores SIGTERM)
                process.kill()
                process.wait()
