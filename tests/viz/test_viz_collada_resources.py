"""Collada and OBJ files made displayable: consistent vertex attributes, embedded textures.

Checked with an XML parser (xml.etree) and the files themselves, not with our regular
expressions; the browser side is tested by tests/model/test_model_all_robots_snapshot.py
(anymal, anymal_c, icub, alex_sake_hands rendered whole, without JavaScript errors).
"""

from __future__ import annotations

import base64
import xml.etree.ElementTree as ET
from pathlib import Path

import example_robot_data
import pytest

from taskspace.viz.collada_resources import (
    WHITE_PNG,
    consistent_attributes,
    consistent_obj,
    texture_resources,
)
from taskspace.viz.meshcat_geometry import collada_file_for_browser

NS = {"c": "http://www.collada.org/2005/11/COLLADASchema"}
ROBOTS = Path(example_robot_data.getModelPath("anymal_b_simple_description/robots/anymal.urdf"))
ANYMAL_BASE = ROBOTS / "anymal_b_simple_description" / "meshes" / "base" / "anymal_base.dae"

TWO_MESHES = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<library_images><image id="t"><init_from>{image}</init_from></image></library_images>
<library_geometries>
<geometry id="a"><mesh>
<source id="a-pos"><float_array id="a-pos-array" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#a-pos-array" count="3" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<source id="a-uv"><float_array id="a-uv-array" count="6">0 0 1 0 0 1</float_array>
<technique_common><accessor source="#a-uv-array" count="3" stride="2">
<param name="S" type="float"/><param name="T" type="float"/></accessor></technique_common>
</source>
<vertices id="a-v"><input semantic="POSITION" source="#a-pos"/></vertices>
<triangles count="1"><input semantic="VERTEX" source="#a-v" offset="0"/>
<input semantic="TEXCOORD" source="#a-uv" offset="1" set="0"/><p>0 0 1 1 2 2</p></triangles>
</mesh></geometry>
<geometry id="b"><mesh>
<source id="b-pos"><float_array id="b-pos-array" count="12">0 0 0 1 0 0 0 1 0 0 0 1</float_array>
<technique_common><accessor source="#b-pos-array" count="4" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<vertices id="b-v"><input semantic="POSITION" source="#b-pos"/></vertices>
<triangles count="2"><input semantic="VERTEX" source="#b-v" offset="0"/><p>0 1 2 0 2 3</p>
</triangles>
</mesh></geometry>
</library_geometries>
</COLLADA>
"""


def _attributes(mesh: ET.Element) -> set[str]:
    semantics = {i.get("semantic", "") for i in mesh.iterfind(".//c:input", NS)}
    return semantics & {"TEXCOORD", "NORMAL", "COLOR"}


def _check_filled(text: str) -> list[ET.Element]:
    """Every mesh has the same attributes; each added source has one value per position."""
    meshes = list(ET.fromstring(text.encode()).iterfind(".//c:mesh", NS))
    assert len({frozenset(_attributes(m)) for m in meshes}) == 1
    for mesh in meshes:
        sources = {s.get("id"): s for s in mesh.iterfind("c:source", NS)}
        vertices = mesh.find("c:vertices", NS)
        assert vertices is not None
        position = vertices.find("c:input[@semantic='POSITION']", NS)
        assert position is not None
        accessor = sources[position.get("source", "")[1:]].find(".//c:accessor", NS)
        assert accessor is not None
        count = int(accessor.get("count", "-1"))
        for added in vertices.iterfind("c:input", NS):
            source = sources[added.get("source", "")[1:]]
            array = source.find("c:float_array", NS)
            access = source.find(".//c:accessor", NS)
            assert array is not None and access is not None and array.text is not None
            stride = int(access.get("stride", "0"))
            assert int(access.get("count", "-1")) == count
            assert len(array.text.split()) == int(array.get("count", "-1")) == stride * count
    return meshes


def test_a_mesh_without_texture_coordinates_gets_constant_ones() -> None:
    text = consistent_attributes(TWO_MESHES.format(image="x.png"))
    meshes = _check_filled(text)
    assert [sorted(_attributes(m)) for m in meshes] == [["TEXCOORD"], ["TEXCOORD"]]
    # the triangles of both meshes are unchanged
    assert "<p>0 0 1 1 2 2</p>" in text and "<p>0 1 2 0 2 3</p>" in text


def test_files_whose_meshes_agree_are_unchanged() -> None:
    one = TWO_MESHES.format(image="x.png")
    only_a = one[: one.index('<geometry id="b">')] + one[one.index("</library_geometries>") :]
    assert consistent_attributes(only_a) is only_a


def test_anymal_base_meshes_agree_after_the_fix() -> None:
    raw = ANYMAL_BASE.read_text()
    kinds = {
        frozenset(_attributes(m)) for m in ET.fromstring(raw.encode()).iterfind(".//c:mesh", NS)
    }
    assert len(kinds) > 1  # the defect: 3 of the meshes have texture coordinates
    text, resources = collada_file_for_browser(str(ANYMAL_BASE.resolve()))
    _check_filled(text)
    ((name, url),) = resources
    assert name == "base_uv_texture.jpg"
    assert url.startswith("data:image/jpeg;base64,")
    assert base64.b64decode(url.split(",", 1)[1]) == (ANYMAL_BASE.parent / name).read_bytes()


def test_missing_or_absolute_texture_images(tmp_path: Path) -> None:
    image = tmp_path / "dir with space" / "t.png"
    image.parent.mkdir()
    image.write_bytes(b"\x89PNG fake")
    uri = image.as_uri()  # file:// with a percent-escaped space
    found = texture_resources(TWO_MESHES.format(image=uri), tmp_path)
    assert base64.b64decode(found[uri].split(",", 1)[1]) == b"\x89PNG fake"
    relative = texture_resources(TWO_MESHES.format(image="dir with space/t.png"), tmp_path)
    assert relative["dir with space/t.png"] == found[uri]
    assert texture_resources(TWO_MESHES.format(image="gone.png"), tmp_path) == {
        "gone.png": WHITE_PNG
    }


@pytest.mark.parametrize(
    ("faces", "expected"),
    [
        ("f 1/1/1 2/2/2 3/3/3\nf 1//1 3//3 4//4\n", "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n"),
        ("f 1/1/1 2/2/2 3/3/3\nf 1/1 3/3 4/4\n", "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"),
        ("f 1/1/1 2/2/2 3/3/3\nf 1 3 4\n", "f 1 2 3\nf 1 3 4\n"),
        ("f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n", None),
    ],
)
def test_obj_faces_agree(faces: str, expected: str | None) -> None:
    head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\n" * 1
    text = head + faces
    fixed = consistent_obj(text)
    if expected is None:
        assert fixed is text
    else:
        assert fixed == head + expected
