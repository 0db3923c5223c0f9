"""Line-numbered diagnosis of URDF files.

Pinocchio's URDF parser (urdfdom) reports a malformed file as "does not contain a valid URDF
model" and prints the cause on stderr; it also accepts a few descriptions that are not
physical (a joint whose lower limit is above its upper limit, a negative mass). This module
reads the file with Python's XML parser, which keeps line numbers, and names the first
problem as ``file:line: what is wrong``.

* :func:`urdf_problem` finds why urdfdom refused a file (XML syntax, a missing ``<robot>``,
  an unknown joint type, a parent or child link that is not defined, a number that is not
  one, a joint without its ``<parent>``/``<child>``);
* :func:`urdf_physical_problem` finds what urdfdom accepts but is wrong (lower limit above
  upper limit, negative or non-finite mass, NaN or infinite limits).
"""

from __future__ import annotations

import math
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


@dataclass
class _Element:
    tag: str
    attrs: dict[str, str]
    line: int
    children: list[_Element] = field(default_factory=list)

    def find(self, tag: str) -> _Element | None:
        return next((c for c in self.children if c.tag == tag), None)


def _parse(data: bytes) -> _Element:
    """The element tree of ``data`` with the line of every start tag.

    Raises:
        xml.parsers.expat.ExpatError: malformed XML (with ``lineno``).
    """
    parser = xml.parsers.expat.ParserCreate()
    stack: list[_Element] = []
    roots: list[_Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = _Element(tag, attrs, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.Parse(data, True)
    return roots[0]


def _read(path: Path) -> tuple[_Element | None, str | None]:
    """(root element, None) or (None, ``file:line: problem``)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        return None, f"{path}: cannot read: {exc.strerror or exc}"
    try:
        return _parse(data), None
    except xml.parsers.expat.ExpatError as exc:
        message = xml.parsers.expat.ErrorString(exc.code)
        return None, f"{path}:{exc.lineno}: not well-formed XML ({message}, column {exc.offset})"
    except IndexError:  # no element at all
        return None, f"{path}:1: no XML element (an empty file?)"


def _float(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _numbers(text: str) -> list[float] | None:
    values = [_float(t) for t in text.split()]
    return None if any(v is None for v in values) else [v for v in values if v is not None]


def urdf_problem(path: str | Path) -> str | None:
    """The first structural problem of a URDF file as ``file:line: problem``, or None.

    Called when Pinocchio refused the file, to say why and where.
    """
    path = Path(path)
    root, problem = _read(path)
    if root is None:
        return problem
    if root.tag != "robot":
        return f"{path}:{root.line}: the root element is <{root.tag}>, a URDF needs <robot>"
    links = {c.attrs.get("name") for c in root.children if c.tag == "link"}
    for element in root.children:
        if element.tag == "link" and not element.attrs.get("name"):
            return f"{path}:{element.line}: a <link> without a name"
        if element.tag != "joint":
            continue
        name = element.attrs.get("name")
        where = f"{path}:{element.line}: joint '{name}'"
        if not name:
            return f"{path}:{element.line}: a <joint> without a name"
        jtype = element.attrs.get("type")
        if jtype not in JOINT_TYPES:
            return f"{where}: unknown type {jtype!r} (URDF types: {', '.join(JOINT_TYPES)})"
        for tag in ("parent", "child"):
            ref = element.find(tag)
            if ref is None or not ref.attrs.get("link"):
                return f"{where}: no <{tag} link=...>"
            if ref.attrs["link"] not in links:
                link = ref.attrs["link"]
                return f"{path}:{ref.line}: joint '{name}': {tag} link '{link}' is not defined"
        for child in element.children:
            for key, text in child.attrs.items():
                if child.tag in ("parent", "child", "mimic") and key in ("link", "joint"):
                    continue
                if _numbers(text) is None:
                    return (
                        f"{path}:{child.line}: joint '{name}': <{child.tag} {key}={text!r}> "
                        "is not a number"
                    )
    return _physical(path, root)


def urdf_mimic_joints(path: str | Path) -> dict[str, str]:
    """Joints of a URDF that mimic another: name -> ``"= m * other + c"`` (its ``<mimic>``)."""
    root, _ = _read(Path(path))
    found: dict[str, str] = {}
    for element in root.children if root is not None else []:
        mimic = element.find("mimic") if element.tag == "joint" else None
        if mimic is not None:
            multiplier = mimic.attrs.get("multiplier", "1")
            offset = mimic.attrs.get("offset", "0")
            other = mimic.attrs.get("joint", "?")
            found[element.attrs.get("name", "?")] = f"= {multiplier} * {other} + {offset}"
    return found


def urdf_physical_problem(path: str | Path) -> str | None:
    """The first value Pinocchio accepts but that is not physical, as ``file:line: ...``."""
    path = Path(path)
    root, _ = _read(path)
    return None if root is None else _physical(path, root)


def _physical(path: Path, root: _Element) -> str | None:
    for element in root.children:
        name = element.attrs.get("name")
        if element.tag == "joint":
            limit = element.find("limit")
            if limit is None:
                continue
            values = {k: _float(v) for k, v in limit.attrs.items()}
            for key, value in values.items():
                if value is not None and math.isnan(value):
                    return f"{path}:{limit.line}: joint '{name}': limit {key} is NaN"
            lower, upper = values.get("lower"), values.get("upper")
            if (
                element.attrs.get("type") in ("revolute", "prismatic")
                and lower is not None
                and upper is not None
                and lower > upper
            ):
                return (
                    f"{path}:{limit.line}: joint '{name}': lower limit {lower:g} is above its "
                    f"upper limit {upper:g}"
                )
        elif element.tag == "link":
            inertial = element.find("inertial")
            mass = inertial.find("mass") if inertial is not None else None
            if mass is not None:
                value = _float(mass.attrs.get("value", ""))
                if value is not None and not (math.isfinite(value) and value >= 0):
                    return (
                        f"{path}:{mass.line}: link '{name}': mass {value:g} is not >= 0 and finite"
                    )
    return None


def srdf_problem(path: str | Path) -> str | None:
    """The first problem of an SRDF file as ``file:line: problem``, or None.

    Problems: malformed XML, a root element other than ``<robot>``, a ``group_state`` joint
    value that is not a number (Pinocchio skips that posture with a line on stdout) or not
    finite (Pinocchio reads ``nan`` as 0). Links
    and joints the model does not have are not problems: example-robot-data shares one SRDF
    between variants of a robot (talos, talos_arm...), and Pinocchio ignores them.
    """
    path = Path(path)
    root, problem = _read(path)
    if root is None:
        return problem
    if root.tag != "robot":
        return f"{path}:{root.line}: the root element is <{root.tag}>, an SRDF needs <robot>"
    for element in root.children:
        if element.tag != "group_state":
            continue
        for joint in element.children:
            value = joint.attrs.get("value", "")
            numbers = _numbers(value) if joint.tag == "joint" else [0.0]
            if numbers in (None, []):
                return (
                    f"{path}:{joint.line}: group_state '{element.attrs.get('name')}': joint "
                    f"'{joint.attrs.get('name')}' value {value!r} is not a number"
                )
            if numbers is not None and not all(math.isfinite(v) for v in numbers):
                # Pinocchio read 'nan' as 0 (the posture silently at zero there)
                return (
                    f"{path}:{joint.line}: group_state '{element.attrs.get('name')}': joint "
                    f"'{joint.attrs.get('name')}' value {value!r} is not finite"
                )
    return None
