"""Antipodal synthesis on meshes and Panda placement, re-checked independently."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.grasping import (
    AntipodalOptions,
    box_mesh,
    cylinder_mesh,
    force_closure,
    place_grasps,
    sample_antipodal_grasps,
    sphere_mesh,
)
from taskspace.model import Robot


def test_meshes_are_closed_outward_and_rays_exit_where_expected() -> None:
    rng = np.random.default_rng(0)
    for mesh, volume in (
        (box_mesh([0.1, 0.2, 0.3]), 0.006),
        (sphere_mesh(0.05, 3), 4 / 3 * np.pi * 0.05**3),
        (cylinder_mesh(0.03, 0.1, 64), np.pi * 0.03**2 * 0.1),
    ):
        # divergence theorem: sum of (centroid . normal) area / 3 is the enclosed volume
        t = mesh.triangles
        enclosed = np.sum(np.einsum("fk,fk->f", t.mean(axis=1), mesh.face_normals) * mesh.areas) / 3
        assert enclosed == pytest.approx(volume, rel=0.02)
        points, normals, _ = mesh.sample_surface(50, rng)
        dist, _ = mesh.ray_exit(points - 1e-6 * normals, -normals)
        assert np.all(np.isfinite(dist))
    box = box_mesh([0.1, 0.2, 0.3])
    origins = np.array([[0.0, 0.0, 0.0], [-0.05, 0.0, 0.0], [0.0, 0.5, 0.0]])
    dirs = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    dist, _ = box.ray_exit(origins + 1e-9, dirs)
    assert dist[0] == pytest.approx(0.05) and dist[1] == pytest.approx(0.1)
    assert np.isnan(dist[2])


@pytest.mark.parametrize("mesh", [box_mesh([0.05, 0.06, 0.12]), cylinder_mesh(0.03, 0.12)])
def test_antipodal_candidates_are_in_force_closure(mesh) -> None:
    candidates = sample_antipodal_grasps(
        mesh, np.random.default_rng(1), AntipodalOptions(samples=300)
    )
    assert len(candidates) > 20
    assert np.all(np.diff(candidates.epsilon) <= 1e-15)  # best first
    assert np.all(candidates.width <= 0.08) and np.all(candidates.epsilon > 0)
    for i in range(0, len(candidates), max(1, len(candidates) // 15)):
        assert force_closure(candidates.contacts(i), method="lp").closure


def test_panda_places_collision_free_grasps_on_a_box() -> None:
    robot = Robot.load(
        "panda", locked_values={"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    )
    mesh = box_mesh([0.04, 0.05, 0.15])
    object_pose = pin.SE3(np.eye(3), np.array([0.5, 0.0, 0.3]))
    rng = np.random.default_rng(2)
    candidates = sample_antipodal_grasps(mesh, rng, AntipodalOptions(samples=300))
    placed = place_grasps(robot, mesh, object_pose, candidates, rng, top=8, approaches=6, want=1)
    feasible = [g for g in placed if g.feasible]
    assert feasible, [(g.reached, g.collision_free) for g in placed]
    assert len(robot.world) == 0  # the object was removed again
    # Independent checks with Pinocchio and coal alone.
    model, geom_model = robot.model, robot.collision_model
    data, geom_data = model.createData(), geom_model.createData()
    object_geom = mesh.collision_geometry()
    for grasp in feasible:
        pin.framesForwardKinematics(model, data, grasp.q)
        tcp = data.oMf[model.getFrameId("panda_hand_tcp")]
        assert np.allclose(tcp.homogeneous, grasp.tool_pose.homogeneous, atol=1e-5)
        pin.updateGeometryPlacements(model, data, geom_model, geom_data)
        for k, obj in enumerate(geom_model.geometryObjects):
            request, result = coal.DistanceRequest(), coal.DistanceResult()
            d = coal.distance(
                obj.geometry,
                coal.Transform3s(geom_data.oMg[k]),
                object_geom,
                coal.Transform3s(object_pose),
                request,
                result,
            )
            assert d > 0, obj.name
