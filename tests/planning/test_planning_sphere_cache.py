"""The on-disk cache of sphere models (issue 22): a cached model is the model the fitting and
the certificate compute (compared with ``cache=False``, which computes and writes nothing),
any change of what the spheres depend on is a new entry (content keys, never a stale
answer), and a damaged entry is recomputed, never trusted.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import taskspace.planning.sphere_model as sm
from taskspace.planning.sphere_model import (
    SphereModel,
    SphereModelOptions,
    sphere_cache_directory,
    sphere_model,
)

FAST = SphereModelOptions(spheres_per_geometry=6, surface_spacing=0.01, interior_spacing=0.02)


def _tetrahedron(height: float) -> coal.BVHModelOBBRSS:
    """A tetrahedron mesh whose apex is at ``height`` [m]."""
    v = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.08, 0.0], [0.02, 0.02, height]])
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(4, 4)
    for a, b, c in ((0, 2, 1), (0, 1, 3), (1, 2, 3), (2, 0, 3)):
        mesh.addTriangle(v[a], v[b], v[c])
    mesh.endModel()
    return mesh


def _geometry_model() -> pin.GeometryModel:
    """Three shapes on two joints: a box, a capsule and a small mesh."""
    geom = pin.GeometryModel()
    box = pin.GeometryObject("box", 1, pin.SE3.Identity(), coal.Box(0.1, 0.2, 0.05))
    cap = pin.GeometryObject(
        "capsule", 2, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.1])), coal.Capsule(0.03, 0.2)
    )
    mesh = pin.GeometryObject("mesh", 2, pin.SE3.Identity(), _tetrahedron(0.06))
    for obj in (box, cap, mesh):
        geom.addGeometryObject(obj)
    return geom


def _same(a: SphereModel, b: SphereModel) -> bool:
    return (
        np.array_equal(a.centers, b.centers)
        and np.array_equal(a.radii, b.radii)
        and np.array_equal(a.joints, b.joints)
        and a.names == b.names
    )


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("TASKSPACE_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TASKSPACE_SPHERE_CACHE", raising=False)
    assert sphere_cache_directory() == tmp_path / "spheres"
    return tmp_path / "spheres"


def test_cached_model_is_the_computed_model(cache_dir: Path, panda) -> None:  # type: ignore[no-untyped-def]
    moving = range(panda.robot_geometry_count)
    cold = sphere_model(panda.collision_model, moving, options=FAST)
    entries = sorted(cache_dir.glob("*.npz"))
    assert entries  # one per distinct non-sphere geometry (the fingers share one)
    warm = sphere_model(panda.collision_model, moving, options=FAST)
    fresh = sphere_model(panda.collision_model, moving, options=FAST, cache=False)
    assert _same(cold, fresh) and _same(warm, fresh)
    assert sorted(cache_dir.glob("*.npz")) == entries  # nothing rewritten or added
    assert warm.certified_margin == fresh.certified_margin > 0.0


def test_cache_false_and_the_switch_write_nothing(
    cache_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sphere_model(_geometry_model(), options=FAST, cache=False)
    assert not cache_dir.exists()
    monkeypatch.setenv("TASKSPACE_SPHERE_CACHE", "0")
    sphere_model(_geometry_model(), options=FAST)
    assert not cache_dir.exists()


def test_every_input_of_the_spheres_is_part_of_the_key(cache_dir: Path) -> None:
    geom = _geometry_model()
    base = sphere_model(geom, options=FAST)
    n0 = len(list(cache_dir.glob("*.npz")))
    assert n0 == 3
    # a box of another size, a capsule of another length, a moved mesh vertex, other options
    changed = _geometry_model()
    changed.geometryObjects[0].geometry = coal.Box(0.1, 0.2, 0.07)
    changed.geometryObjects[1].geometry = coal.Capsule(0.03, 0.25)
    changed.geometryObjects[2].geometry = _tetrahedron(0.061)
    got = sphere_model(changed, options=FAST)
    want = sphere_model(changed, options=FAST, cache=False)
    assert _same(got, want) and not _same(got, base)
    assert len(list(cache_dir.glob("*.npz"))) == n0 + 3
    other = SphereModelOptions(spheres_per_geometry=5, surface_spacing=0.01, interior_spacing=0.02)
    got = sphere_model(geom, options=other)
    assert _same(got, sphere_model(geom, options=other, cache=False))
    assert len(list(cache_dir.glob("*.npz"))) == n0 + 6


def test_a_change_of_this_module_is_a_new_key(
    cache_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sphere_model(_geometry_model(), options=FAST)
    monkeypatch.setattr(sm, "_SOURCE_DIGEST", "another version of sphere_model.py")
    sphere_model(_geometry_model(), options=FAST)
    assert len(list(cache_dir.glob("*.npz"))) == 6


def test_the_placement_is_applied_after_the_cache(cache_dir: Path) -> None:
    geom = _geometry_model()
    sphere_model(geom, options=FAST)
    moved = _geometry_model()
    moved.geometryObjects[0].placement = pin.SE3(np.eye(3), np.array([0.3, 0.0, 0.0]))
    got = sphere_model(moved, options=FAST)  # the box's entry is reused, placed elsewhere
    assert len(list(cache_dir.glob("*.npz"))) == 3
    assert _same(got, sphere_model(moved, options=FAST, cache=False))


@pytest.mark.parametrize("damage", ["garbage", "radii", "truncated", "key"])
def test_a_damaged_entry_is_recomputed(
    cache_dir: Path, damage: str, caplog: pytest.LogCaptureFixture
) -> None:
    geom = _geometry_model()
    want = sphere_model(geom, options=FAST, cache=False)
    sphere_model(geom, options=FAST)
    for path in cache_dir.glob("*.npz"):
        if damage == "garbage":
            path.write_bytes(b"not an npz file")
        elif damage == "truncated":
            path.write_bytes(path.read_bytes()[:100])
        else:
            with np.load(path) as f:
                data = {k: f[k] for k in f.files}
            if damage == "radii":  # smaller spheres, stale checksum: no longer a cover
                data["radii"] = data["radii"] * 0.5
            else:
                data["key"] = np.array("0" * 64)
            np.savez(path, **data)
    with caplog.at_level(logging.WARNING, logger="taskspace.planning.sphere_model"):
        got = sphere_model(geom, options=FAST)
    assert _same(got, want)
    assert "recomputed" in caplog.text
    assert _same(sphere_model(geom, options=FAST), want)  # rewritten, now valid


def test_an_unwritable_cache_still_answers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("the cache directory cannot be created below a file")
    monkeypatch.setenv("TASKSPACE_CACHE_DIR", str(blocker))
    geom = _geometry_model()
    assert _same(sphere_model(geom, options=FAST), sphere_model(geom, options=FAST, cache=False))


def test_threads_writing_the_same_entries(cache_dir: Path) -> None:
    geom = _geometry_model()
    want = sphere_model(geom, options=FAST, cache=False)
    out: list[SphereModel] = []
    errors: list[BaseException] = []

    def work() -> None:
        try:
            out.append(sphere_model(_geometry_model(), options=FAST))
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(out) == 4
    assert all(_same(m, want) for m in out)
    assert len(list(cache_dir.glob("*.npz"))) == 3  # no temporary file left
    assert not list(cache_dir.glob("*.tmp*"))
