"""Multi-finger hand placement (close-until-contact) on the Allegro hand.

References independent of the placement code: coal's collision test and distances on the final
configuration (recomputed from scratch with Pinocchio's geometry placements), the mesh itself
(contact points on its surface), the convex-hull closure test (the placement uses the LP), and
the joint limits (a finger joint that stopped early must have a touching link).
"""

from __future__ import annotations

import warnings

import coal
import numpy as np
import pinocchio as pin
import pytest

from benchmarks.ferrari_canny_reference import epsilon_reference
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.grasping import (
    Finger,
    Hand,
    StartsInCollisionError,
    TriangleMesh,
    close_hand,
    cylinder_mesh,
    force_closure,
    primitive_wrenches,
    sample_hand_grasps,
    sphere_mesh,
)

TOLERANCE = 1e-3


@pytest.fixture(scope="module")
def hand():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Allegro's default posture is clipped on load
        return Hand.allegro()


@pytest.fixture(scope="module")
def grasps(hand):
    out = {}
    for name, mesh in (("sphere", sphere_mesh(0.04)), ("cylinder", cylinder_mesh(0.03, 0.12))):
        out[name] = (mesh, sample_hand_grasps(hand, mesh, 8, rng=np.random.default_rng(3)))
    return out


def hand_object_distances(hand, mesh, grasp):
    """coal distances of every hand geometry to the object, from scratch (palm = world)."""
    robot = hand.robot
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    pin.framesForwardKinematics(robot.model, data, grasp.q)
    pin.updateGeometryPlacements(robot.model, data, robot.collision_model, gdata, grasp.q)
    palm = data.oMf[robot.frame_id(hand.palm_frame)]
    M = palm * grasp.object_pose
    obj = mesh.collision_geometry()
    to = coal.Transform3s(M.rotation, M.translation)
    distances, collides = [], []
    for g, geom in enumerate(robot.collision_model.geometryObjects):
        Mg = gdata.oMg[g]
        tg = coal.Transform3s(Mg.rotation, Mg.translation)
        res = coal.CollisionResult()
        coal.collide(geom.geometry, tg, obj, to, coal.CollisionRequest(), res)
        collides.append(res.isCollision())
        dres = coal.DistanceResult()
        coal.distance(geom.geometry, tg, obj, to, coal.DistanceRequest(), dres)
        distances.append(dres.min_distance)
    return np.array(distances), np.array(collides)


@pytest.mark.slow  # 12 placements on the Allegro hand (a few seconds)
def test_grasps_never_penetrate_and_touch_where_they_say(hand, grasps):
    for name, (mesh, found) in grasps.items():
        assert found, name
        for grasp in found:
            distances, collides = hand_object_distances(hand, mesh, grasp)
            assert not collides.any(), name
            assert distances.min() > 0.0
            assert grasp.min_distance == pytest.approx(distances.min(), abs=1e-9)
            names = [g.name for g in hand.robot.collision_model.geometryObjects]
            for contact in grasp.contacts:
                # the touching link is within the tolerance of the object
                assert distances[names.index(contact.frame)] <= TOLERANCE + 1e-9
                # the contact point lies on the mesh surface, its normal points inward
                p = contact.position
                planes = np.einsum("fi,fi->f", mesh.face_normals, p - mesh.triangles[:, 0])
                assert planes.max() == pytest.approx(0.0, abs=1e-6), name
                assert np.dot(contact.normal, p) < 0  # inward: toward the (convex) center


@pytest.mark.slow
def test_closure_agrees_with_the_hull_test_and_most_grasps_hold(hand, grasps):
    for name, (_, found) in grasps.items():
        held = [g for g in found if g.success]
        assert len(held) >= 3, (name, [g.touching for g in found])
        for grasp in found:
            hull = force_closure(grasp.contacts, method="hull") if grasp.contacts else None
            assert grasp.closure.closure == bool(hull and hull.closure), name
            assert (grasp.epsilon > 0) == grasp.closure.closure
            assert not grasp.self_collision
        assert [g.epsilon for g in held] == sorted((g.epsilon for g in held), reverse=True)


@pytest.mark.slow
def test_a_finger_stops_early_only_against_something(hand, grasps):
    robot = hand.robot
    model = robot.model
    gmodel = robot.collision_model
    for name, (mesh, found) in grasps.items():
        for grasp in found:
            distances, _ = hand_object_distances(hand, mesh, grasp)
            data, gdata = model.createData(), gmodel.createData()
            pin.computeDistances(model, data, gmodel, gdata, grasp.q)
            link = {
                (p.first, p.second): gdata.distanceResults[k].min_distance
                for k, p in enumerate(gmodel.collisionPairs)
            }
            for finger in hand.fingers:
                for joint, closed in zip(finger.joints, finger.closed):
                    jid = model.getJointId(joint)
                    if abs(grasp.q[model.idx_qs[jid]] - closed) < 1e-9:
                        continue  # closed all the way
                    carried = [
                        g
                        for g, geom in enumerate(gmodel.geometryObjects)
                        if geom.parentJoint in model.subtrees[jid]
                    ]
                    near_object = min(distances[g] for g in carried)
                    near_link = min(
                        (d for (a, b), d in link.items() if (a in carried) != (b in carried)),
                        default=np.inf,
                    )
                    assert min(near_object, near_link) <= TOLERANCE + 1e-9, (name, joint)


def test_bad_hands_and_placements_are_refused(hand):
    with pytest.raises(UnknownNameError, match=r"joint_1\.0"):
        Hand(
            hand.robot,
            "palm_link",
            hand.approach,
            hand.preshape,
            (Finger("x", ("no_such_joint",), (0.1,)),),
        )
    with pytest.raises(InvalidInputError, match="outside its limits"):
        Hand(
            hand.robot,
            "palm_link",
            hand.approach,
            hand.preshape,
            (Finger("x", ("joint_1.0",), (9.0,)),),
        )
    with pytest.raises(InvalidInputError, match="approach"):
        Hand(hand.robot, "palm_link", np.zeros(3), hand.preshape, hand.fingers)
    with pytest.raises(StartsInCollisionError):
        close_hand(hand, sphere_mesh(0.04), pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.05])))
    for bad in ([np.nan, 0.0, 0.03], [np.inf, 0.0, 0.03], [1e300, 0.0, 0.03]):
        with pytest.raises(InvalidInputError, match="finite and within"):
            close_hand(hand, sphere_mesh(0.04), pin.SE3(np.eye(3), np.array(bad)))
    with pytest.raises(InvalidInputError, match="tolerance"):
        close_hand(hand, sphere_mesh(0.04), pin.SE3.Identity(), tolerance=-1.0)


def test_an_object_beside_the_hand_is_never_touched(hand):
    far = pin.SE3(np.eye(3), np.array([0.1, 0.5, 0.03]))  # approach passes beside the hand
    assert close_hand(hand, sphere_mesh(0.03), far) is None


def test_linf_epsilon_of_many_contacts_is_refused_not_left_running():
    from taskspace.errors import SolverError
    from taskspace.grasping import GraspContact, epsilon_linf, grasp_quality, primitive_wrenches

    rng = np.random.default_rng(0)
    points = rng.normal(size=(10, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    contacts = [GraspContact(0.04 * p, -p) for p in points]
    W, owner = primitive_wrenches(contacts, edges=8)
    with pytest.raises(SolverError, match="MAX_LINF_POINTS"):
        epsilon_linf(W, owner, native=False)
    quality = grasp_quality(contacts, linf=False)
    assert np.isnan(quality.epsilon_linf) and quality.epsilon_l1 > 0
    from taskspace._native import planning_kernel

    if planning_kernel() is not None:  # the compiled kernel needs only the sum's support
        linf = epsilon_linf(W, owner)
        assert linf >= quality.epsilon_l1  # the L-infinity space contains the L1 one
        u = rng.normal(size=(2000, 6))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        owners = np.asarray(owner)
        support = sum(np.maximum(0, (u @ W[owners == i].T).max(axis=1)) for i in range(10))
        assert linf <= support.min() + 1e-12  # the ball of radius epsilon is inside


def test_epsilon_is_about_the_center_of_mass_wherever_the_mesh_origin_is(hand):
    # before: moments about the mesh frame's origin: the same grasp of the same cylinder,
    # its file's origin 6 cm off its center, scored 0.042 instead of 0.083
    mesh = cylinder_mesh(0.03, 0.12)
    d = np.array([0.05, -0.02, 0.03])
    shifted = TriangleMesh(mesh.vertices + d, mesh.faces)
    np.testing.assert_allclose(shifted.centroid, d, atol=1e-12)  # the axis midpoint, analytic
    found = sample_hand_grasps(hand, mesh, 3, rng=np.random.default_rng(3))
    found = [g for g in found if g.closure.closure]
    assert found
    for g in found:
        # the same physical placement, the mesh described in the shifted frame
        moved = close_hand(hand, shifted, g.object_pose * pin.SE3(np.eye(3), -d), approach=False)
        assert moved.closure.closure and len(moved.contacts) == len(g.contacts)
        # the textbook epsilon (one QP per hull facet) with moments about the analytic center
        W, _ = primitive_wrenches(moved.contacts, edges=8, center=d)
        assert moved.epsilon == pytest.approx(epsilon_reference(W), rel=1e-6)
        assert moved.epsilon == pytest.approx(g.epsilon, rel=1e-9)
