"""Conversion of Pinocchio/coal geometry and of markers to meshcat scene objects.

Everything returned here is a meshcat *command* (an object with ``lower() -> dict``) or a
meshcat geometry/material pair; :class:`~taskspace.viz.viewer.Viewer` sends them to a
:class:`~taskspace.viz.scene_recorder.SceneRecorder`. three.js conventions: cylinders and cones
are built along their local ``y`` axis, so markers are placed with a rotation that maps ``y``
onto the wanted direction.
"""

from __future__ import annotations

import functools
import logging
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_float_array
from taskspace.errors import InvalidInputError
from taskspace.viz.collada_resources import (
    consistent_attributes,
    consistent_obj,
    texture_resources,
)

logger = logging.getLogger(__name__)


def rgb_int(color: Any) -> int:
    """An RGB(A) color in [0, 1] as the integer ``0xRRGGBB`` used by three.js."""
    c = np.clip(parse_color(color)[:3], 0.0, 1.0)
    r, g, b = (round(255 * x) for x in c)
    return (r << 16) + (g << 8) + b


def parse_color(color: Any, name: str = "color") -> FloatArray:
    """Normalize a color to RGBA in [0, 1].

    Args:
        color: RGB or RGBA in [0, 1], or an integer ``0xRRGGBB``.
        name: argument name used in error messages.
    """
    if isinstance(color, (int, np.integer)) and not isinstance(color, (bool, np.bool_)):
        value = int(color)
        if not 0 <= value <= 0xFFFFFF:
            # -1 was masked to white and 0x1000000 to black
            raise InvalidInputError(
                f"{name} as an integer must be 0xRRGGBB in [0, 0xFFFFFF], got {value:#x}"
            )
        return np.array(
            [((value >> 16) & 255) / 255, ((value >> 8) & 255) / 255, (value & 255) / 255, 1.0]
        )
    arr = as_float_array(color, name).ravel()
    if arr.shape not in ((3,), (4,)) or not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name} must be RGB or RGBA in [0, 1], got {color!r}")
    if arr.min() < -1e-9 or arr.max() > 1.0 + 1e-9:
        # (128, 128, 128) was clipped to white without a word
        hint = " (0..255 values? divide by 255)" if arr.max() <= 255.0 else ""
        raise InvalidInputError(
            f"{name} must be RGB or RGBA with entries in [0, 1], got {color!r}{hint}; "
            "or an integer 0xRRGGBB"
        )
    if arr.shape == (3,):
        arr = np.append(arr, 1.0)
    return np.clip(arr, 0.0, 1.0)


def phong(color: Any, *, on_top: bool = False) -> Any:
    """A ``MeshPhongMaterial`` of RGBA ``color`` (transparent when alpha < 1).

    Args:
        color: RGB(A) in [0, 1].
        on_top: draw over everything (no depth test; rendered with the transparent objects,
            after the opaque ones), e.g. for forces or a center of mass inside the robot.
    """
    import meshcat.geometry as mg

    rgba = parse_color(color)
    extra: dict[str, Any] = {"depthTest": False} if on_top else {}
    material = mg.MeshPhongMaterial(color=rgb_int(rgba), **extra)
    if rgba[3] < 1.0 or on_top:
        material.transparent = True
        material.opacity = float(rgba[3])
    return material


def rotation_y_to(direction: Any) -> FloatArray:
    """Rotation matrix mapping the unit ``y`` axis onto ``direction`` (normalized).

    Rodrigues' formula ``R = I + [w]x + [w]x^2 / (1 + c)`` with ``w = y x d``, ``c = y . d``;
    the antiparallel case is a half turn about ``x``.
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    y = np.array([0.0, 1.0, 0.0])
    c = float(y @ d)
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    w = np.cross(y, d)
    wx = pin.skew(w)
    return np.eye(3) + wx + wx @ wx / (1.0 + c)


def homogeneous(rotation: Any = None, translation: Any = None) -> FloatArray:
    """4x4 homogeneous matrix from a rotation (default identity) and a translation [m]."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    if translation is not None:
        T[:3, 3] = translation
    return T


class ConeGeometry:
    """three.js ``ConeGeometry`` (axis along local ``y``, centered at half height)."""

    def __init__(self, height: float, radius: float, radial_segments: int = 24) -> None:
        import meshcat.geometry as mg

        self._base = mg.Geometry()
        self.uuid = self._base.uuid
        self.height = float(height)
        self.radius = float(radius)
        self.radial_segments = int(radial_segments)

    def intrinsic_transform(self) -> FloatArray:
        """Identity (meshcat's geometry interface)."""
        return np.eye(4)

    def lower_in_object(self, object_data: dict[str, Any]) -> str:
        """Add this geometry to a lowered object (meshcat's geometry interface)."""
        object_data["geometries"].append(self.lower(object_data))
        return self.uuid

    def lower(self, object_data: Any = None) -> dict[str, Any]:
        """The three.js JSON of the geometry."""
        return {
            "uuid": self.uuid,
            "type": "ConeGeometry",
            "radius": self.radius,
            "height": self.height,
            "radialSegments": self.radial_segments,
        }


class DaeObjectCommand:
    """A ``set_object`` command of a Collada file with its own materials (``_meshfile_object``).

    Keeps the colors written in the ``.dae`` file (e.g. the Panda's white and black links),
    which meshcat's ``DaeMeshGeometry`` (geometry only) loses, and its texture images
    (embedded as ``data:`` URLs; see :func:`collada_file_for_browser`).
    """

    def __init__(self, path: str, dae_file: str | Path, material: Any = None) -> None:
        import meshcat.geometry as mg

        self.path = path
        self.uuid = mg.Geometry().uuid
        self.data, resources = collada_file_for_browser(str(Path(dae_file).resolve()))
        self.resources = dict(resources)
        self.material = material

    def lower(self) -> dict[str, Any]:
        """The lowered ``set_object`` command."""
        obj: dict[str, Any] = {
            "metadata": {"version": 4.5, "type": "Object"},
            "geometries": [],
            "materials": [],
            "object": {
                "uuid": self.uuid,
                "type": "_meshfile_object",
                "format": "dae",
                "data": self.data,
                "resources": self.resources,
                "matrix": list(np.eye(4).flatten()),
            },
        }
        if self.material is not None:
            self.material.lower_in_object(obj)
        return {"type": "set_object", "path": self.path, "object": obj}


COLLADA_DIGITS = 5
"""Significant digits kept in Collada float arrays, relative to each array's largest value."""

_FLOAT_ARRAY = re.compile(r"(<float_array[^>]*>)([^<]*)(</float_array>)")


def compact_collada(text: str, digits: int = COLLADA_DIGITS) -> str:
    """Collada text with every ``<float_array>`` cut to ``digits`` significant digits.

    The decimals of each array ``v`` beyond ``d = digits - 1 - floor(log10(max|v|))`` are
    dropped from the text: a vertex moves by less than one unit of the last kept digit
    (10 um for coordinates below 1 m with 5 digits), far below a pixel, and the text
    compresses much better. Numbers in exponent form are kept as written.
    """
    if digits < 1:
        raise InvalidInputError(f"digits must be >= 1, got {digits}")

    def shortened(match: re.Match[str]) -> str:
        numbers = match.group(2)
        try:
            values = np.array(numbers.split(), dtype=float)
        except ValueError:
            return match.group(0)
        biggest = float(np.max(np.abs(values))) if values.size else 0.0
        if not np.isfinite(biggest) or biggest == 0.0:
            return match.group(0)
        decimals = digits - 1 - math.floor(math.log10(biggest))
        if decimals < 1:
            return match.group(0)
        cut = re.sub(rf"(?<=\.\d{{{decimals}}})\d+(?=\s|$)", "", numbers)
        return match.group(1) + cut + match.group(3)

    return _FLOAT_ARRAY.sub(shortened, text)


@functools.lru_cache(maxsize=64)
def compact_collada_file(path: str) -> str:
    """:func:`compact_collada` of a ``.dae`` file (cached: robots share and reload meshes)."""
    return compact_collada(Path(path).read_text(encoding="utf-8", errors="replace"))


STL_MANTISSA_BITS = 13
"""Mantissa bits kept in the float32 numbers of binary STL files (of 23)."""

_STL_TRIANGLE = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", 9), ("attribute", "<u2")])


def compact_stl(data: bytes, mantissa_bits: int = STL_MANTISSA_BITS) -> bytes:
    """Binary STL with the low mantissa bits of its normals and vertices set to zero.

    A number keeps its relative precision ``2**-mantissa_bits`` (1.2e-4 for 13 bits: 60 um
    at 0.5 m), far below a pixel, and the file compresses much better. ASCII STL files and
    files whose size does not match their triangle count are returned unchanged.
    """
    if not 1 <= mantissa_bits <= 23:
        raise InvalidInputError(f"mantissa_bits must be within 1..23, got {mantissa_bits}")
    if len(data) < 84:
        return data
    count = int(np.frombuffer(data, "<u4", count=1, offset=80)[0])
    if len(data) != 84 + _STL_TRIANGLE.itemsize * count:
        return data
    triangles = np.frombuffer(data, _STL_TRIANGLE, offset=84).copy()
    mask = np.uint32((0xFFFFFFFF << (23 - mantissa_bits)) & 0xFFFFFFFF)
    for field in ("normal", "vertices"):
        bits = triangles[field].view("<u4")
        bits &= mask
    return data[:84] + triangles.tobytes()


@functools.lru_cache(maxsize=128)
def compact_stl_file(path: str) -> bytes:
    """:func:`compact_stl` of a file (cached: robots share and reload meshes)."""
    return compact_stl(Path(path).read_bytes())


@functools.lru_cache(maxsize=64)
def collada_file_for_browser(path: str) -> tuple[str, tuple[tuple[str, str], ...]]:
    """A ``.dae`` file as meshcat's viewer needs it: text and texture resources (cached).

    The text is :func:`compact_collada` of the file with every mesh given the same vertex
    attributes (:func:`~taskspace.viz.collada_resources.consistent_attributes`); the resources
    are ``(image name, data URL)`` pairs of its textures
    (:func:`~taskspace.viz.collada_resources.texture_resources`).
    """
    text = consistent_attributes(compact_collada_file(path))
    resources = texture_resources(text, Path(path).parent)
    return text, tuple(resources.items())


@functools.lru_cache(maxsize=64)
def obj_file_for_browser(path: str) -> str:
    """An ``.obj`` file whose faces agree on texture and normal indices (cached).

    See :func:`~taskspace.viz.collada_resources.consistent_obj`.
    """
    return consistent_obj(Path(path).read_text(encoding="utf-8", errors="replace"))


def _mesh_file_geometry(mesh_path: str) -> Any:
    import meshcat.geometry as mg

    suffix = Path(mesh_path).suffix.lower()
    if suffix == ".stl":
        import umsgpack

        contents = compact_stl_file(str(Path(mesh_path).resolve()))
        _, code = mg.threejs_type(np.uint8)
        return mg.MeshGeometry(umsgpack.Ext(code, contents), "stl")
    if suffix == ".obj":
        return mg.MeshGeometry(obj_file_for_browser(str(Path(mesh_path).resolve())), "obj")
    if suffix == ".dae":
        return mg.DaeMeshGeometry.from_file(mesh_path)
    return None


def primitive_geometry(geometry: Any) -> tuple[Any, FloatArray] | None:
    """A meshcat geometry for a coal primitive and the fixed transform to apply to it.

    Returns ``None`` for shapes without a primitive counterpart. Cylinders, capsules and
    cones of coal are along ``z``; three.js builds them along ``y``: the returned transform
    is the rotation of +90 deg about ``x`` (``y -> z``).
    """
    import coal
    import meshcat.geometry as mg

    y_to_z = homogeneous(rotation_y_to([0.0, 0.0, 1.0]))
    if isinstance(geometry, coal.Box):
        return mg.Box(list(2.0 * np.asarray(geometry.halfSide))), np.eye(4)
    if isinstance(geometry, coal.Sphere):
        return mg.Sphere(float(geometry.radius)), np.eye(4)
    if isinstance(geometry, coal.Ellipsoid):
        radii = np.asarray(geometry.radii, dtype=float)
        return mg.Sphere(1.0), homogeneous(np.diag(radii))
    if isinstance(geometry, coal.Capsule):
        # Drawn as a cylinder of the full length (caps omitted).
        length = 2.0 * float(geometry.halfLength) + 2.0 * float(geometry.radius)
        return mg.Cylinder(length, float(geometry.radius)), y_to_z
    if isinstance(geometry, coal.Cylinder):
        return mg.Cylinder(2.0 * float(geometry.halfLength), float(geometry.radius)), y_to_z
    if isinstance(geometry, coal.Cone):
        return ConeGeometry(2.0 * float(geometry.halfLength), float(geometry.radius)), y_to_z
    return None


def geometry_commands(
    path: str, geometry_object: pin.GeometryObject, color: Any = None
) -> tuple[list[Any], FloatArray, bool]:
    """Meshcat commands that create one Pinocchio geometry object under ``path``.

    Args:
        path: scene path of the node (its transform is the geometry placement).
        geometry_object: the Pinocchio geometry (primitive or mesh file).
        color: RGBA override; default the geometry's ``meshColor`` (Collada files keep
            their own materials unless a color is given).

    Returns:
        ``(commands, offset, scaled)``: the commands, a fixed transform to place under the
        node (for primitives along ``z``) and whether the node transform must include
        ``meshScale`` (mesh files are stored unscaled).
    """
    import meshcat.commands as mc
    import meshcat.path as mp

    geom = geometry_object.geometry
    mesh_path = str(geometry_object.meshPath or "")
    # the model's own colors are clipped (a description may overshoot [0, 1]); the user's are
    # checked by parse_color
    rgba = parse_color(
        color if color is not None else np.clip(np.asarray(geometry_object.meshColor), 0, 1)
    )
    node = mp.Path(tuple(p for p in path.split("/") if p))
    prim = primitive_geometry(geom)
    if prim is not None:
        shape, offset = prim
        return [mc.SetObject(shape, phong(rgba), node)], offset, False
    if mesh_path and Path(mesh_path).is_file():
        if Path(mesh_path).suffix.lower() == ".dae":
            material = phong(rgba) if color is not None else None
            return [DaeObjectCommand(path, mesh_path, material)], np.eye(4), True
        shape = _mesh_file_geometry(mesh_path)
        if shape is not None:
            return [mc.SetObject(shape, phong(rgba), node)], np.eye(4), True
    vertices, faces = _bvh_triangles(geom)
    if vertices is not None:
        import meshcat.geometry as mg

        shape = mg.TriangularMeshGeometry(vertices, faces)
        return [mc.SetObject(shape, phong(rgba), node)], np.eye(4), False
    logger.warning("geometry '%s' (%s) cannot be displayed", geometry_object.name, type(geom))
    return [], np.eye(4), False


def _bvh_triangles(geometry: Any) -> tuple[Any, Any]:
    """Vertices and triangles of a coal mesh or convex (``None, None`` if unavailable)."""
    try:
        n_v = int(geometry.num_vertices)
        n_t = int(geometry.num_tris)
        vertices = np.array([geometry.vertices(i) for i in range(n_v)], dtype=float)
        faces = np.array([[geometry.tri_indices(i)[k] for k in range(3)] for i in range(n_t)])
    except Exception:  # not a BVH model, or bindings without accessors
        return None, None
    if n_v == 0 or n_t == 0:
        return None, None
    return vertices, faces


def geometry_aabb(geometry: Any, placement: pin.SE3) -> FloatArray | None:
    """World-space corners (8, 3) of a coal geometry's local bounding box at ``placement``."""
    try:
        geometry.computeLocalAABB()
        lo = np.asarray(geometry.aabb_local.min_, dtype=float)
        hi = np.asarray(geometry.aabb_local.max_, dtype=float)
    except Exception:
        return None
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))) or np.any(hi - lo > 1e3):
        return None
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    return corners @ placement.rotation.T + placement.translation


def tube_mesh(points: FloatArray, radius: float, sides: int = 8) -> tuple[FloatArray, Any]:
    """A triangle mesh of one prism per polyline segment (a tube of ``radius`` [m]).

    Each segment ``p_i -> p_{i+1}`` gets a ring of ``sides`` vertices at both ends in the plane
    orthogonal to its direction; the rings are joined by ``2 sides`` triangles. Vectorized
    over segments.
    """
    p = np.asarray(points, dtype=float)
    a, b = p[:-1], p[1:]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    keep = length > 1e-12
    a, b, d, length = a[keep], b[keep], d[keep], length[keep]
    n_seg = a.shape[0]
    if n_seg == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32)
    d = d / length[:, None]
    ref = np.where(np.abs(d[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    u = np.cross(d, ref)
    u /= np.linalg.norm(u, axis=1)[:, None]
    w = np.cross(d, u)
    ang = 2.0 * np.pi * np.arange(sides) / sides
    ring = radius * (
        np.cos(ang)[None, :, None] * u[:, None, :] + np.sin(ang)[None, :, None] * w[:, None, :]
    )  # (n_seg, sides, 3)
    vertices = np.concatenate([a[:, None, :] + ring, b[:, None, :] + ring], axis=1)
    vertices = vertices.reshape(-1, 3)
    k = np.arange(sides)
    k1 = (k + 1) % sides
    base = (np.arange(n_seg) * 2 * sides)[:, None]
    t1 = np.stack([base + k, base + k1, base + sides + k], axis=-1)
    t2 = np.stack([base + k1, base + sides + k1, base + sides + k], axis=-1)
    faces = np.concatenate([t1, t2], axis=1).reshape(-1, 3).astype(np.uint32)
    return vertices, faces
