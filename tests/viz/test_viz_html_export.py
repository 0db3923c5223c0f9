"""Compact static HTML: meshes stored once, compressed, and the Collada text shortened.

The pages still render: the snapshot tests (test_viz_snapshots.py) load these compressed
pages in headless Chromium and compare them with the reference images.
"""

from __future__ import annotations

import base64
import json
import re
import zlib

import numpy as np
import pytest
import umsgpack

from taskspace.errors import InvalidInputError
from taskspace.viz import Viewer
from taskspace.viz.meshcat_geometry import DaeObjectCommand, compact_collada
from taskspace.viz.scene_recorder import SceneRecorder

MB = 1_000_000


def _scene(html: str) -> dict:
    match = re.search(r"var TASKSPACE_SCENE = (\{.*?\});\n</script>", html, re.S)
    assert match is not None
    return json.loads(match.group(1))


def _commands(html: str) -> list[bytes]:
    """Rebuild the commands of a compressed page as the browser does."""
    scene = _scene(html)
    data = zlib.decompress(base64.b64decode(scene["data"]))
    offsets = np.concatenate([[0], np.cumsum(scene["sizes"])])
    chunks = [data[offsets[i] : offsets[i + 1]] for i in range(len(scene["sizes"]))]
    assert offsets[-1] == len(data)
    return [b"".join(chunks[i] for i in ids) for ids in scene["commands"]]


def _first_collada(robot) -> str:
    return next(
        g.meshPath for g in robot.visual_model.geometryObjects if g.meshPath.endswith(".dae")
    )


@pytest.fixture(scope="module")
def animation(panda) -> tuple[Viewer, str]:
    """A 3 s Panda animation (60 configurations) and its compressed page."""
    viewer = Viewer(panda)
    qs = np.linspace(panda.q_default, panda.q_default + 0.4, 60)
    viewer.play(qs, dt=0.05)
    return viewer, viewer.static_html()


def test_short_panda_animation_is_small(animation):
    viewer, compressed = animation
    plain = viewer.recorder.static_html(compress=False)
    assert len(compressed) < 5 * MB  # a 15 MB page before (Collada text in base64)
    assert len(plain) > 3 * len(compressed)
    assert compressed.count("<script") == 3 and "MeshCat.Viewer" in compressed


def test_compressed_page_holds_the_same_commands(animation):
    viewer, html = animation
    assert _commands(html) == viewer.recorder.packed_commands()
    kinds = [umsgpack.unpackb(c)["type"] for c in _commands(html)]
    assert kinds.count("set_animation") == 1 and kinds[-1] == "set_property"
    js = zlib.decompress(base64.b64decode(_scene(html)["js"])).decode()
    from taskspace.viz.scene_recorder import meshcat_javascript

    assert js == meshcat_javascript()


def test_a_mesh_shown_twice_is_stored_once(panda):
    dae = next(
        g.meshPath for g in panda.visual_model.geometryObjects if g.meshPath.endswith(".dae")
    )
    one, two = SceneRecorder(), SceneRecorder()
    one.send(DaeObjectCommand("/meshcat/a", dae))
    two.send(DaeObjectCommand("/meshcat/a", dae))
    two.send(DaeObjectCommand("/meshcat/b", dae))
    size_one = len(_scene(one.static_html())["data"])
    size_two = len(_scene(two.static_html())["data"])
    assert size_two < size_one + 2000  # the second node costs its path and uuid only
    # and the command still carries the whole mesh text
    commands = [umsgpack.unpackb(c) for c in two.packed_commands()]
    texts = [c["object"]["object"]["data"] for c in commands if c["type"] == "set_object"]
    assert len(texts) == 2 and texts[0] == texts[1] and len(texts[0]) > 10_000


def test_compact_collada_keeps_the_mesh_within_one_unit_of_the_last_digit(panda):
    dae = next(
        g.meshPath for g in panda.visual_model.geometryObjects if g.meshPath.endswith(".dae")
    )
    text = open(dae, encoding="utf-8").read()
    short = compact_collada(text, digits=5)
    assert len(short) < len(text)
    pattern = r"<float_array[^>]*>([^<]*)</float_array>"
    before = [np.array(a.split(), dtype=float) for a in re.findall(pattern, text)]
    after = [np.array(a.split(), dtype=float) for a in re.findall(pattern, short)]
    assert [a.shape for a in before] == [a.shape for a in after]
    for a, b in zip(before, after):
        unit = 10.0 ** (np.floor(np.log10(np.abs(a).max())) - 4)
        assert np.abs(a - b).max() < unit
    # everything but the float arrays is untouched
    assert re.sub(pattern, "", short) == re.sub(pattern, "", text)


def test_compact_collada_edge_cases():
    text = "<float_array>1.23456789 -7.61061e-4 12.5 0.1234567\n0.000012345 3</float_array>"
    assert compact_collada(text, digits=4) == (
        "<float_array>1.23 -7.61061e-4 12.5 0.12\n0.00 3</float_array>"
    )
    zeros = "<float_array count='2'>0 0.0</float_array>"
    assert compact_collada(zeros) == zeros
    with pytest.raises(InvalidInputError, match="digits must be >= 1"):
        compact_collada(text, digits=0)


def test_a_binary_mesh_shown_twice_is_stored_once(robot_loader):
    import meshcat.commands as mc
    import meshcat.geometry as mg
    import meshcat.path as mp

    talos = robot_loader("talos")
    stl = next(g.meshPath for g in talos.visual_model.geometryObjects if g.meshPath[-4:] == ".stl")

    def command(name: str):
        shape = mg.StlMeshGeometry.from_file(stl)
        return mc.SetObject(shape, mg.MeshPhongMaterial(), mp.Path(("meshcat", name)))

    assert isinstance(command("a").lower()["object"]["geometries"][0]["data"], umsgpack.Ext)
    one, two = SceneRecorder(), SceneRecorder()
    one.send(command("a"))
    two.send(command("a"))
    two.send(command("b"))
    assert len(_scene(two.static_html())["data"]) < len(_scene(one.static_html())["data"]) + 2000
    original = command("a").lower()["object"]["geometries"][0]["data"]
    decoded = [umsgpack.unpackb(c) for c in _commands(two.static_html())]
    meshes = [c["object"]["geometries"][0]["data"] for c in decoded if c["type"] == "set_object"]
    assert meshes == [original, original]


def test_compact_stl_keeps_relative_precision(robot_loader):
    from taskspace.viz.meshcat_geometry import compact_stl

    talos = robot_loader("talos")
    stl = next(g.meshPath for g in talos.visual_model.geometryObjects if g.meshPath[-4:] == ".stl")
    data = open(stl, "rb").read()
    short = compact_stl(data, mantissa_bits=13)
    assert len(short) == len(data) and short[:84] == data[:84]
    record = np.dtype([("n", "<f4", 3), ("v", "<f4", 9), ("a", "<u2")])
    before = np.frombuffer(data, record, offset=84)
    after = np.frombuffer(short, record, offset=84)
    assert np.array_equal(before["a"], after["a"])
    for field in ("n", "v"):
        a, b = before[field].astype(float), after[field].astype(float)
        assert np.all(np.abs(a - b) <= np.abs(a) * 2.0**-13)
        assert np.all(np.abs(b) <= np.abs(a))  # truncation towards zero
        assert not np.array_equal(a, b)
    assert len(zlib.compress(short)) < 0.9 * len(zlib.compress(data))


def test_compact_stl_leaves_other_files_alone():
    from taskspace.viz.meshcat_geometry import compact_stl

    ascii_stl = b"solid x\nfacet normal 0 0 1\nendsolid x\n" * 3
    assert compact_stl(ascii_stl) == ascii_stl
    assert compact_stl(b"short") == b"short"
    with pytest.raises(InvalidInputError, match=r"mantissa_bits must be within 1..23"):
        compact_stl(ascii_stl, mantissa_bits=0)
