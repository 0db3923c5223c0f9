"""Mesh files are read once per process, and loads do not keep their meshes forever.

A ``coal.CachedMeshLoader`` created per load and passed to ``buildGeomFromUrdf`` was never
freed with its meshes: every ``Robot.load("panda")`` kept about 76 MB until the process ended
(a 350-problem benchmark ran out of memory). The loads now share one loader; these tests
check the memory (the resident size after 6 loads), that a mesh file
changed on disk is read again (coal compares its modification time), that a convex load does
not change the meshes the other robots share, and concurrent loads.
"""

from __future__ import annotations

import gc
import os
import threading
from pathlib import Path

import coal
import numpy as np
import pytest

from taskspace.model.robot import Robot

URDF = """<robot name="one_mesh">
  <link name="base"/>
  <link name="arm">
    <inertial>
      <mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <collision><geometry><mesh filename="{mesh}"/></geometry></collision>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
  </link>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def _write_tetrahedron(path: Path, height: float) -> None:
    path.write_text(
        "solid t\n"
        + "".join(
            "facet normal 0 0 0\nouter loop\n"
            + "".join(f"vertex {x} {y} {z}\n" for x, y, z in tri)
            + "endloop\nendfacet\n"
            for tri in (
                ((0, 0, 0), (0, 0.1, 0), (0.1, 0, 0)),
                ((0, 0, 0), (0.1, 0, 0), (0, 0, height)),
                ((0.1, 0, 0), (0, 0.1, 0), (0, 0, height)),
                ((0, 0.1, 0), (0, 0, 0), (0, 0, height)),
            )
        )
        + "endsolid t\n"
    )


def _mesh_top(robot: Robot) -> float:
    geometry = robot.collision_model.geometryObjects[0].geometry
    return float(np.asarray(geometry.vertices())[:, 2].max())


def _resident_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="needs /proc (Linux)")
def test_repeated_loads_do_not_keep_their_meshes() -> None:
    Robot.load("panda")
    gc.collect()
    before = _resident_mb()
    for _ in range(6):
        Robot.load("panda")
        gc.collect()
    growth = _resident_mb() - before
    # one leaking load kept ~76 MB of meshes: six kept ~450 MB
    assert growth < 20.0, f"6 loads of the Panda grew the process by {growth:.0f} MB"


def test_a_changed_mesh_file_is_read_again(tmp_path: Path) -> None:
    mesh = tmp_path / "tetra.stl"
    _write_tetrahedron(mesh, 0.1)
    urdf = tmp_path / "one_mesh.urdf"
    urdf.write_text(URDF.format(mesh=mesh))
    first = Robot.from_urdf(urdf)
    assert _mesh_top(first) == pytest.approx(0.1)
    _write_tetrahedron(mesh, 0.3)
    stat = mesh.stat()
    os.utime(mesh, (stat.st_atime, stat.st_mtime + 5.0))  # a later modification time
    second = Robot.from_urdf(urdf)
    assert _mesh_top(second) == pytest.approx(0.3)
    assert _mesh_top(first) == pytest.approx(0.1)  # the first robot keeps its geometry


def test_a_convex_load_leaves_the_shared_meshes_alone(tmp_path: Path) -> None:
    mesh = tmp_path / "tetra.stl"
    _write_tetrahedron(mesh, 0.1)
    urdf = tmp_path / "one_mesh.urdf"
    urdf.write_text(URDF.format(mesh=mesh))
    plain = Robot.from_urdf(urdf)
    convex = Robot.from_urdf(urdf, convex_collision=True)
    assert isinstance(convex.collision_model.geometryObjects[0].geometry, coal.ConvexBase)
    again = Robot.from_urdf(urdf)  # the cached mesh, as read from the file
    for robot in (plain, again):
        assert isinstance(robot._collision_model.geometryObjects[0].geometry, coal.BVHModelBase)
        # the visual model holds the loaded (shared) mesh itself: no hull was built on it
        shared = robot._visual_model.geometryObjects[0].geometry
        assert isinstance(shared, coal.BVHModelBase)
        assert shared.convex is None


def test_concurrent_loads() -> None:
    out: list[Robot] = []
    errors: list[BaseException] = []

    def work() -> None:
        try:
            out.append(Robot.load("ur5"))
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(out) == 4
    q = out[0].neutral()
    assert len({r.is_collision_free(q) for r in out}) == 1
    assert {r.collision_model.ngeoms for r in out} == {out[0].collision_model.ngeoms}
