"""``SceneRecorder``: a meshcat "window" that records scene commands instead of sending them.

meshcat's ``Visualizer`` talks to a window object through ``window.send(command)``. The
recorder implements that interface and keeps the scene as a tree, exactly like meshcat's zmq
server does (``set_object`` replaces a node's object and clears its properties, ``delete``
removes a subtree, the animation is stored once). :meth:`SceneRecorder.static_html` then writes
a self-contained HTML page: meshcat's ``main.min.js`` inlined and every command embedded as
base64 msgpack, decoded and applied *synchronously and in order* (meshcat's own static HTML
uses asynchronous ``fetch`` of ``data:`` URLs). No zmq server, no network access.

The last scene command is always a readiness token: a property ``taskspace_ready_token`` set on
the node ``/taskspace_ready``. The snapshot renderer polls it to know that every command was
applied (see :mod:`taskspace.viz.snapshot`).

A live meshcat window (zmq server) can be attached with ``forward``: commands are then both
recorded and forwarded, so the static HTML always matches what the live viewer shows.
"""

from __future__ import annotations

import base64
import html
import json
import logging
import uuid
from pathlib import Path
from typing import Any, Protocol

logger = logging.getLogger(__name__)

READY_NODE = "taskspace_ready"
"""Top-level scene node that carries the readiness token (not under ``/meshcat``)."""

READY_PROPERTY = "taskspace_ready_token"
"""Property of :data:`READY_NODE` holding the token once every command was applied."""


class _Command(Protocol):
    def lower(self) -> dict[str, Any]: ...


class _Window(Protocol):
    def send(self, command: Any) -> Any: ...


class _Node:
    """One node of the recorded scene tree (mirrors meshcat's server-side ``SceneTree``)."""

    __slots__ = ("animation", "children", "object", "properties", "transform")

    def __init__(self) -> None:
        self.object: bytes | None = None
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


_HTML_TEMPLATE = """<!DOCTYPE html>
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
{javascript}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
window.__taskspace_errors = [];
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
        self.command_count = 0

    # ------------------------------------------------------------------ window interface
    def send(self, command: _Command) -> None:
        """Record one meshcat command (any object with ``lower() -> dict``)."""
        import umsgpack

        data = command.lower()
        kind = data["type"]
        packed = umsgpack.packb(data)
        path = _split(str(data.get("path", "")))
        self.command_count += 1
        if kind == "set_object":
            node = self._root.find(path)
            node.object = packed
            node.properties = []
        elif kind == "set_transform":
            self._root.find(path).transform = packed
        elif kind == "set_property":
            self._root.find(path).properties.append(packed)
        elif kind == "set_animation":
            self._root.find(path).animation = packed
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

    # ------------------------------------------------------------------ export
    def packed_commands(self) -> list[bytes]:
        """All recorded commands (msgpack bytes) in replay order, readiness token last."""
        import umsgpack

        out: list[bytes] = []
        animations: list[bytes] = []
        for node in self._root.walk():
            if node.object is not None:
                out.append(node.object)
            out.extend(node.properties)
            if node.transform is not None:
                out.append(node.transform)
            if node.animation is not None:
                animations.append(node.animation)
        out.extend(animations)
        out.append(
            umsgpack.packb(
                {
                    "type": "set_property",
                    "path": f"/{READY_NODE}",
                    "property": READY_PROPERTY,
                    "value": self.token,
                }
            )
        )
        return out

    def static_html(self, title: str = "taskspace scene") -> str:
        """A self-contained HTML page of the scene (meshcat's JS inlined, no network access).

        Args:
            title: the page title.
        """
        encoded = [base64.b64encode(c).decode("ascii") for c in self.packed_commands()]
        return _HTML_TEMPLATE.format(
            title=html.escape(title),
            javascript=meshcat_javascript(),
            commands=json.dumps(encoded, separators=(",", ":")),
        )

    def close(self) -> None:
        """Nothing to release (the interface of meshcat's ``ViewerWindow``)."""
