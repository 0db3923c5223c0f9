"""``SceneRecorder``: a meshcat "window" that records scene commands instead of sending them.

meshcat's ``Visualizer`` talks to a window object through ``window.send(command)``. The
recorder implements that interface and keeps the scene as a tree, exactly like meshcat's zmq
server does (``set_object`` replaces a node's object and clears its properties, ``delete``
removes a subtree, the animation is stored once). :meth:`SceneRecorder.static_html` then writes
a self-contained HTML page: meshcat's ``main.min.js`` and every command (msgpack) embedded,
applied *in order* (meshcat's own static HTML uses one asynchronous ``fetch`` of a ``data:``
URL per command). No zmq server, no network access.

The page is compact: every byte string (command parts, and each large string such as a mesh
file, cut out of its command) is stored once, however many commands use it (a mesh shown by
several nodes, a scene re-sent); the distinct parts and the viewer's JavaScript are
zlib-compressed and base64-encoded, and inflated in the browser by ``DecompressionStream``
(Chrome 80+, Firefox 113+, Safari 16.4+). ``compress=False`` writes the plain page.

The last scene command is always a readiness token: a property ``taskspace_ready_token`` set on
the node ``/taskspace_ready``. The snapshot renderer polls it to know that every command was
applied (see :mod:`taskspace.viz.snapshot`).

A live meshcat window (zmq server) can be attached with ``forward``: commands are then both
recorded and forwarded, so the static HTML always matches what the live viewer shows.

Thread safety: a :class:`SceneRecorder` is a mutable scene tree (and command count) and is not
locked: one thread at a time, as its :class:`~taskspace.viz.Viewer`.
"""

from __future__ import annotations

import base64
import functools
import html
import json
import logging
import uuid
import zlib
from pathlib import Path
from typing import Any, Protocol

from taskspace.errors import InvalidInputError

logger = logging.getLogger(__name__)

READY_NODE = "taskspace_ready"
"""Top-level scene node that carries the readiness token (not under ``/meshcat``)."""

READY_PROPERTY = "taskspace_ready_token"
"""Property of :data:`READY_NODE` holding the token once every command was applied."""


LARGE_STRING = 4096
"""Strings, bytes and msgpack extensions at least this long (meshes) are stored once per page."""


class _Command(Protocol):
    def lower(self) -> dict[str, Any]: ...


class _Window(Protocol):
    def send(self, command: Any) -> Any: ...


class _Node:
    """One node of the recorded scene tree (mirrors meshcat's server-side ``SceneTree``)."""

    __slots__ = ("animation", "children", "object", "properties", "transform")

    def __init__(self) -> None:
        self.object: tuple[bytes, ...] | None = None
        self.properties: list[bytes] = []
        self.transform: bytes | None = None
        self.animation: bytes | None = None
        self.children: dict[str, _Node] = {}

    def find(self, path: list[str]) -> _Node:
        node = self
        for name in path:
            node = node.children.setdefault(name, _Node())
        return node

    def walk(self) -> list[_Node]:
        out = [self]
        for child in self.children.values():
            out.extend(child.walk())
        return out


def _split(path: str) -> list[str]:
    return [p for p in path.split("/") if p]


def meshcat_javascript() -> str:
    """The source of meshcat's bundled viewer, ``viewer/dist/main.min.js`` (no network use)."""
    import meshcat

    js = Path(meshcat.__file__).resolve().parent / "viewer" / "dist" / "main.min.js"
    return js.read_text(encoding="utf-8")


# The start of both pages: the pane, the error list and the count of texture images still
# loading (the snapshot waits for them).
_PAGE_HEAD = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<script>
window.__taskspace_errors = [];
window.__taskspace_pending_images = 0;
(function () {{
  // texture images (created by three.js' ImageLoader) still loading: the snapshot waits
  var create = document.createElementNS;
  document.createElementNS = function (namespace, name) {{
    var element = create.call(document, namespace, name);
    if (String(name).toLowerCase() === "img") {{
      window.__taskspace_pending_images++;
      var done = function () {{
        window.__taskspace_pending_images--;
        element.removeEventListener("load", done);
        element.removeEventListener("error", done);
      }};
      element.addEventListener("load", done);
      element.addEventListener("error", done);
    }}
    return element;
  }};
}})();
</script>
"""

_HTML_TEMPLATE = (
    _PAGE_HEAD
    + """<script>
{javascript}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
(function () {{
  var commands = {commands};
  for (var k = 0; k < commands.length; k++) {{
    try {{
      var text = atob(commands[k]);
      var bytes = new Uint8Array(text.length);
      for (var i = 0; i < text.length; i++) {{ bytes[i] = text.charCodeAt(i); }}
      viewer.handle_command_bytearray(bytes);
    }} catch (err) {{
      window.__taskspace_errors.push("command " + k + ": " + err);
    }}
  }}
}})();
</script>
</body>
</html>
"""
)


_COMPRESSED_TEMPLATE = (
    _PAGE_HEAD
    + """<script>
var TASKSPACE_SCENE = {scene};
</script>
<script>
(async function () {{
  function inflate(text) {{
    var raw = atob(text);
    var bytes = new Uint8Array(raw.length);
    for (var i = 0; i < raw.length; i++) {{ bytes[i] = raw.charCodeAt(i); }}
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer().then(function (b) {{ return new Uint8Array(b); }});
  }}
  var scene = TASKSPACE_SCENE;
  (0, eval)(new TextDecoder().decode(await inflate(scene.js)));
  window.viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  // a mesh file shown by several nodes (a quadruped's legs) is parsed once and cloned
  // (geometry and materials shared) while the recorded commands are replayed
  var parseObject = viewer.set_object_from_json;
  var parsed = new Map();
  viewer.set_object_from_json = function (path, json) {{
    var o = json && json.object, key = null;
    if (o && o.type === "_meshfile_object" && typeof o.data === "string") {{
      key = [o.format, JSON.stringify(json.materials || []), JSON.stringify(o.resources || {{}}),
             o.data].join("\u0000");
      var known = parsed.get(key);
      if (known !== undefined) {{
        viewer.set_object(path, known.clone());
        viewer.set_dirty();
        return;
      }}
    }}
    parseObject.call(viewer, path, json);
    var made = viewer.scene_tree.find(path.concat(["<object>"])).object;
    if (made && Array.isArray(made.material)) {{
      // meshcat merges the meshes of a file with one material slot per mesh; a mesh with
      // several materials filled its slot with an array, which three.js draws as nothing
      // (icub's shanks): such a mesh is drawn in its first material
      made.material = made.material.map(function (m) {{ return Array.isArray(m) ? m[0] : m; }});
    }}
    if (key !== null) {{ parsed.set(key, made); }}
  }};
  var data = await inflate(scene.data);
  var offsets = [0];
  for (var c = 0; c < scene.sizes.length; c++) {{ offsets.push(offsets[c] + scene.sizes[c]); }}
  for (var k = 0; k < scene.commands.length; k++) {{
    try {{
      var ids = scene.commands[k], length = 0, at = 0;
      for (var j = 0; j < ids.length; j++) {{ length += scene.sizes[ids[j]]; }}
      var command = new Uint8Array(length);
      for (var j = 0; j < ids.length; j++) {{
        command.set(data.subarray(offsets[ids[j]], offsets[ids[j] + 1]), at);
        at += scene.sizes[ids[j]];
      }}
      viewer.handle_command_bytearray(command);
    }} catch (err) {{
      window.__taskspace_errors.push("command " + k + ": " + err);
    }}
  }}
  viewer.set_object_from_json = parseObject;
  parsed.clear();
}})().catch(function (err) {{
  window.__taskspace_errors.push("loading the scene: " + err);
  var hint = typeof DecompressionStream === "undefined" ? " (this page needs a browser with "
    + "DecompressionStream: Chrome 80+, Firefox 113+, Safari 16.4+)" : "";
  document.body.insertAdjacentText("afterbegin", "could not load the scene: " + err + hint);
}});
</script>
</body>
</html>
"""
)


@functools.lru_cache(maxsize=1)
def _compressed_javascript() -> str:
    """The viewer's JavaScript (``main.min.js``), zlib-compressed and base64-encoded, once."""
    packed = zlib.compress(meshcat_javascript().encode("utf-8"), 9)
    return base64.b64encode(packed).decode("ascii")


class SceneRecorder:
    """Records meshcat commands into a scene tree and writes them as static HTML.

    Use it as the ``window`` of a ``meshcat.Visualizer``:
    ``meshcat.Visualizer(window=SceneRecorder())``; every ``set_object``, ``set_transform``,
    ``set_property``, ``set_animation`` and ``delete`` is recorded.

    Attributes:
        forward: optional live meshcat window that also receives every command.
        token: the readiness token written as the last command of the static HTML.
    """

    def __init__(self, forward: _Window | None = None) -> None:
        self.forward = forward
        self.token = uuid.uuid4().hex
        self._root = _Node()
        self._shared: dict[bytes, bytes] = {}
        self.command_count = 0

    # ------------------------------------------------------------------ window interface
    def send(self, command: _Command) -> None:
        """Record one meshcat command (any object with ``lower() -> dict``)."""
        import umsgpack

        data = command.lower()
        kind = data["type"]
        path = _split(str(data.get("path", "")))
        self.command_count += 1
        if kind == "set_object":
            node = self._root.find(path)
            node.object = self._pack_parts(data)
            node.properties = []
        elif kind == "set_transform":
            self._root.find(path).transform = umsgpack.packb(data)
        elif kind == "set_property":
            self._root.find(path).properties.append(umsgpack.packb(data))
        elif kind == "set_animation":
            self._root.find(path).animation = umsgpack.packb(data)
        elif kind == "delete":
            if path:
                parent = self._root.find(path[:-1])
                parent.children.pop(path[-1], None)
            else:
                self._root = _Node()
        else:
            logger.debug("meshcat command %r is not recorded", kind)
        if self.forward is not None:
            self.forward.send(command)

    def _pack_parts(self, data: dict[str, Any]) -> tuple[bytes, ...]:
        """The msgpack of ``data`` cut around its large strings (each kept once, by content).

        msgpack encodes a string as a self-delimiting header plus its bytes, so the command is
        the concatenation of the parts; a large string (a mesh file) becomes a part of its own,
        shared by every command that carries the same text.
        """
        import umsgpack

        large: dict[str, Any] = {}

        def cut(value: Any) -> Any:
            if isinstance(value, dict):
                return {k: cut(v) for k, v in value.items()}
            if isinstance(value, list):
                return [cut(v) for v in value]
            if isinstance(value, umsgpack.Ext):
                size = len(value.data)
            else:
                size = len(value) if isinstance(value, str | bytes) else 0
            if size >= LARGE_STRING:
                marker = f"\x00taskspace-part-{len(large)}\x00"
                large[marker] = value
                return marker
            return value

        packed = umsgpack.packb(cut(data))
        parts: list[bytes] = []
        for marker, text in large.items():
            head, _, packed = packed.partition(umsgpack.packb(marker))
            whole = umsgpack.packb(text)
            parts += [head, self._shared.setdefault(whole, whole)]
        parts.append(packed)
        return tuple(p for p in parts if p)

    # ------------------------------------------------------------------ export
    def _ordered_parts(self) -> list[tuple[bytes, ...]]:
        """Every recorded command as its parts, in replay order, readiness token last."""
        import umsgpack

        out: list[tuple[bytes, ...]] = []
        animations: list[tuple[bytes, ...]] = []
        for node in self._root.walk():
            if node.object is not None:
                out.append(node.object)
            out.extend((p,) for p in node.properties)
            if node.transform is not None:
                out.append((node.transform,))
            if node.animation is not None:
                animations.append((node.animation,))
        out.extend(animations)
        token = {
            "type": "set_property",
            "path": f"/{READY_NODE}",
            "property": READY_PROPERTY,
            "value": self.token,
        }
        out.append((umsgpack.packb(token),))
        return out

    def packed_commands(self) -> list[bytes]:
        """All recorded commands (msgpack bytes) in replay order, readiness token last."""
        return [b"".join(parts) for parts in self._ordered_parts()]

    def static_html(
        self, title: str = "taskspace scene", *, compress: bool = True, level: int = 6
    ) -> str:
        """A self-contained HTML page of the scene (meshcat's JS inlined, no network access).

        Args:
            title: the page title.
            compress: store each distinct part once, zlib-compressed, inflated by the browser
                (``DecompressionStream``); ``False`` writes every command in plain base64.
            level: zlib level (1 fastest, 9 smallest); snapshots use 1 for their temporary
                page (about 3x faster to write than 6 for mesh-heavy scenes).
        """
        if isinstance(level, bool) or not isinstance(level, int) or not 1 <= level <= 9:
            raise InvalidInputError(f"level must be an integer in 1..9, got {level!r}")
        if not compress:
            encoded = [base64.b64encode(c).decode("ascii") for c in self.packed_commands()]
            return _HTML_TEMPLATE.format(
                title=html.escape(title),
                javascript=meshcat_javascript(),
                commands=json.dumps(encoded, separators=(",", ":")),
            )
        chunks: dict[bytes, int] = {}
        commands = [
            [chunks.setdefault(part, len(chunks)) for part in parts]
            for parts in self._ordered_parts()
        ]
        scene = {
            "js": _compressed_javascript(),
            "data": base64.b64encode(zlib.compress(b"".join(chunks), level)).decode("ascii"),
            "sizes": [len(chunk) for chunk in chunks],
            "commands": commands,
        }
        return _COMPRESSED_TEMPLATE.format(
            title=html.escape(title), scene=json.dumps(scene, separators=(",", ":"))
        )

    def close(self) -> None:
        """Nothing to release (the interface of meshcat's ``ViewerWindow``)."""
