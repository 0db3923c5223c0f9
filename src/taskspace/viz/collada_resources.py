"""Collada files made displayable by meshcat's viewer: consistent vertex attributes, textures.

meshcat's viewer parses a ``.dae`` file with three.js' ``ColladaLoader`` and merges every mesh
of the file into one ``BufferGeometry`` (``mergeBufferGeometries``). Two things made robots of
example-robot-data render wrong, with only JavaScript console errors as a sign:

* **Attributes**: the merge needs every mesh to carry the same vertex attributes. In
  anymal's base, 3 of 24 meshes have texture coordinates and the others none; the merge then
  fails and the whole file (the robot's base) is not drawn ("Cannot set properties of null
  (setting 'material')"). :func:`consistent_attributes` gives each mesh that lacks an
  attribute some other mesh of the file has a constant one (texture coordinate ``(0, 0)``,
  white vertex color, or a normal ``(0, 0, 1)``), through an input of the mesh's
  ``<vertices>`` element (indexed like the positions; the triangle lists are unchanged).
* The same holds for Wavefront OBJ files: alex's arms mix faces with and without texture
  coordinates (``f 1/2/3`` and ``f 1//3``), and the merge failed the same way.
  :func:`consistent_obj` drops the component (texture coordinate or normal) that only some
  faces have: meshcat's viewer draws OBJ files without their material library, so texture
  coordinates are unused, and missing normals are computed by the viewer.
* **Textures**: images are named relative to the ``.dae`` file (``base_uv_texture.jpg``);
  the page is loaded from elsewhere, so the browser looked for ``/tmp/base_uv_texture.jpg``
  and the ``file:`` request was refused. :func:`texture_resources` maps each image name of
  ``<library_images>`` to a ``data:`` URL of the file (meshcat's ``resources`` of a
  ``_meshfile_object``, applied by the loader's URL modifier). An image that does not exist
  (tiago's ``xtion_pro_live.png``) becomes a 1x1 white PNG, with a log message: the surface
  keeps its material color.

Thread safety: functions of their arguments (the file reads are cached; the cache is locked).
"""

from __future__ import annotations

import base64
import functools
import logging
import mimetypes
import re
import urllib.parse
from pathlib import Path

logger = logging.getLogger(__name__)

__all__ = ["MAX_TEXTURE_BYTES", "consistent_attributes", "consistent_obj", "texture_resources"]

MAX_TEXTURE_BYTES = 16 * 1024 * 1024
"""Texture images larger than this are not embedded (the surface keeps its material color)."""

WHITE_PNG = (
    "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8"
    "/5+hHgAHggJ/PchI7wAAAABJRU5ErkJggg=="
)
"""A 1x1 white PNG: stands in for a texture image that is missing or too large."""

_MESH = re.compile(r"<mesh\b[^>]*>.*?</mesh>", re.DOTALL)
_VERTICES = re.compile(r"(<vertices\b[^>]*>)(.*?)(</vertices>)", re.DOTALL)
_INPUT = re.compile(r"<input\b[^>]*\bsemantic=\"([A-Z0-9_]+)\"[^>]*>")
_POSITION_SOURCE = re.compile(r"<input\b[^>]*semantic=\"POSITION\"[^>]*source=\"#([^\"]+)\"")
_POSITION_SOURCE_FIRST = re.compile(r"<input\b[^>]*source=\"#([^\"]+)\"[^>]*semantic=\"POSITION\"")
_ACCESSOR_COUNT = re.compile(r"<accessor\b[^>]*\bcount=\"(\d+)\"")
_IMAGES = re.compile(r"<library_images\b[^>]*>(.*?)</library_images>", re.DOTALL)
_INIT_FROM = re.compile(r"<init_from>\s*([^<]*?)\s*</init_from>")

# attribute: (components, the constant value written, parameter names)
_FILL = {
    "TEXCOORD": (2, "0", ("S", "T")),
    "NORMAL": (3, None, ("X", "Y", "Z")),  # (0, 0, 1)
    "COLOR": (3, "1", ("R", "G", "B")),
}


def _semantics(mesh: str) -> set[str]:
    """The vertex attributes of one ``<mesh>`` (of its primitives and its ``<vertices>``)."""
    return {s for s in _INPUT.findall(mesh) if s in _FILL}


def _vertex_count(mesh: str) -> int | None:
    """The number of positions of a mesh (the ``count`` of its POSITION source's accessor)."""
    vertices = _VERTICES.search(mesh)
    if vertices is None:
        return None
    found = _POSITION_SOURCE.search(vertices.group(2)) or _POSITION_SOURCE_FIRST.search(
        vertices.group(2)
    )
    if found is None:
        return None
    source = re.search(
        rf"<source\b[^>]*\bid=\"{re.escape(found.group(1))}\"[^>]*>(.*?)</source>", mesh, re.DOTALL
    )
    count = _ACCESSOR_COUNT.search(source.group(1)) if source is not None else None
    return int(count.group(1)) if count is not None else None


def _constant_source(ident: str, semantic: str, count: int) -> str:
    size, value, params = _FILL[semantic]
    if semantic == "NORMAL":
        numbers = " ".join(["0 0 1"] * count)
    else:
        numbers = " ".join([value or "0"] * (size * count))
    param_xml = "".join(f'<param name="{p}" type="float"/>' for p in params)
    return (
        f'<source id="{ident}"><float_array id="{ident}-array" count="{size * count}">{numbers}'
        f'</float_array><technique_common><accessor source="#{ident}-array" count="{count}" '
        f'stride="{size}">{param_xml}</accessor></technique_common></source>'
    )


def consistent_attributes(text: str) -> str:
    """Collada text whose meshes all carry the same vertex attributes (see the module doc).

    Each mesh that lacks ``TEXCOORD``, ``NORMAL`` or ``COLOR`` while another mesh of the file
    has it gets a constant source of that attribute, one value per position, as an input of its
    ``<vertices>``. A file whose meshes agree is returned unchanged (the same string). A mesh
    whose position count cannot be read is left as it is.
    """
    meshes = list(_MESH.finditer(text))
    kinds = [_semantics(m.group(0)) for m in meshes]
    union = set().union(*kinds) if kinds else set()
    if all(k == union for k in kinds):
        return text
    out: list[str] = []
    at = 0
    for index, (match, have) in enumerate(zip(meshes, kinds)):
        missing = sorted(union - have)
        mesh = match.group(0)
        count = _vertex_count(mesh) if missing else None
        vertices = _VERTICES.search(mesh)
        if missing and count is not None and vertices is not None:
            sources = "".join(
                _constant_source(f"taskspace-fill-{index}-{s.lower()}", s, count) for s in missing
            )
            inputs = "".join(
                f'<input semantic="{s}" source="#taskspace-fill-{index}-{s.lower()}"/>'
                for s in missing
            )
            mesh = (
                mesh[: vertices.start()]
                + sources
                + vertices.group(1)
                + vertices.group(2)
                + inputs
                + vertices.group(3)
                + mesh[vertices.end() :]
            )
        elif missing:
            logger.info("a Collada mesh lacks %s and its positions cannot be counted", missing)
        out += [text[at : match.start()], mesh]
        at = match.end()
    out.append(text[at:])
    return "".join(out)


@functools.lru_cache(maxsize=64)
def _data_url(path: str) -> str | None:
    """A ``data:`` URL of an image file (``None`` if missing or larger than the limit)."""
    file = Path(path)
    try:
        size = file.stat().st_size
    except OSError:
        return None
    if not file.is_file() or size > MAX_TEXTURE_BYTES:
        return None
    mime = mimetypes.guess_type(file.name)[0] or "application/octet-stream"
    return f"data:{mime};base64," + base64.b64encode(file.read_bytes()).decode("ascii")


def texture_resources(text: str, directory: str | Path) -> dict[str, str]:
    """``{image name as written in the file: data URL}`` for the images of a Collada file.

    Names are resolved relative to ``directory`` (the ``.dae`` file's folder); ``file://``
    URLs and percent-escapes are understood. A missing or too large image maps to
    :data:`WHITE_PNG` (logged).
    """
    resources: dict[str, str] = {}
    for block in _IMAGES.findall(text):
        for name in _INIT_FROM.findall(block):
            if not name or name in resources or name.startswith("data:"):
                continue
            target = urllib.parse.unquote(name.removeprefix("file://"))
            path = Path(target) if Path(target).is_absolute() else Path(directory) / target
            url = _data_url(str(path.resolve()))
            if url is None:
                logger.info("texture image %s is missing or too large: drawn untextured", path)
                url = WHITE_PNG
            resources[name] = url
    return resources


_OBJ_FACE = re.compile(r"^(f[ \t]+)(.*)$", re.MULTILINE)


def consistent_obj(text: str) -> str:
    """OBJ text whose faces all have, or all lack, texture and normal indices.

    A component (``vt`` or ``vn`` index) given by only some faces is dropped from every face
    (``1/2/3`` becomes ``1//3`` or ``1/2``); a file whose faces agree is returned unchanged.
    """
    kinds: set[tuple[bool, bool]] = set()
    for match in _OBJ_FACE.finditer(text):
        for vertex in match.group(2).split():
            parts = vertex.split("/")
            kinds.add((len(parts) > 1 and parts[1] != "", len(parts) > 2 and parts[2] != ""))
    if len(kinds) <= 1:
        return text
    keep_texture = all(t for t, _ in kinds)
    keep_normal = all(n for _, n in kinds)

    def rewrite(match: re.Match[str]) -> str:
        out = []
        for vertex in match.group(2).split():
            parts = [*vertex.split("/"), "", ""]
            texture = parts[1] if keep_texture else ""
            normal = parts[2] if keep_normal else ""
            out.append(
                parts[0] + (f"/{texture}/{normal}" if normal else f"/{texture}" if texture else "")
            )
        return match.group(1) + " ".join(out)

    return _OBJ_FACE.sub(rewrite, text)
