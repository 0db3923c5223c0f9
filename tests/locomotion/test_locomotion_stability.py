"""Support polygon, static stability, ZMP two ways, CoP (references: scipy's convex hull,
Newton-Euler through Pinocchio's RNEA, force-weighted point means)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.locomotion import (
    ContactWrench,
    SupportPolygon,
    center_of_pressure,
    robot_feet,
    static_stability,
    support_polygon,
    zmp_from_dynamics,
    zmp_from_wrenches,
)


def test_polygon_matches_scipy_hull(rng):
    pts = rng.normal(size=(40, 2))
    poly = SupportPolygon.from_points(pts)
    hull = ConvexHull(pts)
    assert poly.area == pytest.approx(hull.volume, rel=1e-12)
    assert set(map(tuple, np.round(poly.vertices, 12))) == set(
        map(tuple, np.round(pts[hull.vertices], 12))
    )
    for p in rng.normal(size=(50, 2)):
        inside = np.all(hull.equations[:, :2] @ p + hull.equations[:, 2] <= 0)
        assert poly.contains(p) == inside
        if inside:  # margin = distance to the nearest edge line
            ref = np.min(-(hull.equations[:, :2] @ p + hull.equations[:, 2]))
            assert poly.margin(p) == pytest.approx(ref, abs=1e-12)


def test_degenerate_polygons():
    seg = SupportPolygon.from_points([[0, 0], [1, 0], [0.5, 0]])
    assert seg.is_degenerate and seg.vertices.shape == (2, 2)
    assert seg.margin([0.5, 0.2]) == pytest.approx(-0.2)
    assert seg.margin([2.0, 0.0]) == pytest.approx(-1.0)
    point = SupportPolygon.from_points([[1.0, 2.0, 0.3]])
    assert point.margin([1.0, 2.5]) == pytest.approx(-0.5)
    with pytest.raises(InvalidInputError, match="is_degenerate"):
        seg.halfspaces()


def test_outside_margin_is_distance_to_polygon():
    square = SupportPolygon.from_points([[0, 0], [1, 0], [1, 1], [0, 1]])
    assert square.margin([0.5, 0.5]) == pytest.approx(0.5)
    assert square.margin([2.0, 2.0]) == pytest.approx(-np.sqrt(2))
    assert square.margin([0.5, -0.3]) == pytest.approx(-0.3)
    assert square.centroid == pytest.approx([0.5, 0.5])


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_standing_robot_is_statically_stable(robot_loader, name):
    robot = robot_loader(name)
    feet = list(robot_feet(name).values())
    q = robot.q_default
    res = static_stability(robot, q, feet, margin=0.01)
    assert res.stable and res.margin > 0.01
    corners = np.vstack([f.vertices_in_world(robot.frame_placement(q, f.frame)) for f in feet])
    assert res.polygon.area == pytest.approx(ConvexHull(corners[:, :2]).volume, rel=1e-9)
    # the feet are on the ground plane of the default posture
    support_polygon(robot, q, feet, ground_height=float(corners[:, 2].mean()))
    # one foot: the CoM between the feet is outside that foot's polygon
    one = static_stability(robot, q, feet[:1])
    assert not one.stable and one.margin < 0
    # a required margin larger than the polygon allows
    assert not static_stability(robot, q, feet, margin=0.5).stable


def test_unknown_robot_feet_lists_valid():
    with pytest.raises(UnknownNameError, match="g1, talos"):
        robot_feet("panda")


def _point_jacobian(robot, data, frame_id, point):
    J = pin.getFrameJacobian(robot.model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)
    r = point - data.oMf[frame_id].translation
    return J[:3] - pin.skew(r) @ J[3:]


def _consistent_motion(robot, rng, q, v, contacts):
    """Joint accelerations at random, base acceleration from the 6 base rows of
    ``M a + h = J^T f`` (the contacts are the only external forces)."""
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    Jtf = np.zeros(model.nv)
    for kind, fid, point, w in contacts:
        if kind == "local":
            Jtf += pin.getFrameJacobian(model, data, fid, pin.LOCAL).T @ w
        else:
            Jtf += _point_jacobian(robot, data, fid, point).T @ w
    a = rng.normal(size=model.nv)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.rnea(model, data, q, v, np.zeros(model.nv))
    a[:6] = np.linalg.solve(M[:6, :6], Jtf[:6] - h[:6] - M[:6, 6:] @ a[6:])
    tau = pin.rnea(model, data, q, v, a) - Jtf
    assert np.abs(tau[:6]).max() < 1e-8  # the base is unactuated: forces balance
    return a


@pytest.mark.parametrize("trial", range(4))
def test_zmp_from_dynamics_equals_zmp_from_wrenches_talos(robot_loader, rng, trial):
    robot = robot_loader("talos")
    feet = robot_feet("talos")
    rng = np.random.default_rng(trial)
    q = robot.q_default.copy()
    q[7:] += 0.1 * rng.normal(size=robot.nv - 6)
    q[:3] += 0.05 * rng.normal(size=3)
    v = rng.normal(size=robot.nv)
    contacts, wrenches = [], []
    for foot in feet.values():
        fid = robot.frame_id(foot.frame)
        w = np.concatenate(
            [rng.normal(size=2) * 30, [300 + 200 * rng.random()], rng.normal(size=3) * 5]
        )
        contacts.append(("local", fid, None, w))
        wrenches.append(ContactWrench.from_local(robot.frame_placement(q, foot.frame), w))
    a = _consistent_motion(robot, rng, q, v, contacts)
    for height in (0.0, 0.1):
        p_dyn = zmp_from_dynamics(robot, q, v, a, height=height)
        p_wr = zmp_from_wrenches(wrenches, height=height)
        assert np.abs(p_dyn - p_wr).max() < 1e-9


@pytest.mark.parametrize("trial", range(3))
def test_zmp_agree_with_point_contacts_g1(robot_loader, trial):
    robot = robot_loader("g1")
    feet = robot_feet("g1")
    rng = np.random.default_rng(100 + trial)
    q = robot.q_default.copy()
    q[7:] += 0.1 * rng.normal(size=robot.nv - 6)
    v = rng.normal(size=robot.nv)
    contacts, wrenches = [], []
    for foot in feet.values():
        M = robot.frame_placement(q, foot.frame)
        fid = robot.frame_id(foot.frame)
        for p in foot.vertices_in_world(M):
            f = np.array([*(10 * rng.normal(size=2)), 40 + 40 * rng.random()])
            contacts.append(("point", fid, p, f))
            wrenches.append(ContactWrench.point_force(p, f))
    a = _consistent_motion(robot, rng, q, v, contacts)
    z = float(np.mean([w.point[2] for w in wrenches]))
    assert (
        np.abs(zmp_from_dynamics(robot, q, v, a, z) - zmp_from_wrenches(wrenches, z)).max() < 1e-9
    )


def test_cop_is_force_weighted_mean_of_pressure_points(rng):
    placement = pin.SE3(pin.rpy.rpyToMatrix(0, 0, 0.7), np.array([0.3, -0.2, 0.0]))
    pts_local = np.column_stack(
        [rng.uniform(-0.1, 0.1, 6), rng.uniform(-0.05, 0.05, 6), np.zeros(6)]
    )
    fz = rng.uniform(1, 50, 6)
    # wrench about the sole origin of vertical pressure forces (plus tangential ones)
    ft = rng.normal(size=(6, 2))
    forces = np.column_stack([ft, fz])
    wrench = np.concatenate([forces.sum(0), np.cross(pts_local, forces).sum(0)])
    expected = (fz @ pts_local) / fz.sum()
    assert center_of_pressure(wrench) == pytest.approx(expected, abs=1e-12)
    assert center_of_pressure(wrench, placement) == pytest.approx(
        placement.act(expected), abs=1e-12
    )
    # the ZMP of one flat foot is its CoP
    zmp = zmp_from_wrenches([ContactWrench.from_local(placement, wrench)])
    assert zmp == pytest.approx(placement.act(expected), abs=1e-12)


def test_zmp_refuses_flight():
    with pytest.raises(InvalidInputError, match="f_z > 0"):
        zmp_from_wrenches([ContactWrench.point_force([0, 0, 0], [1.0, 0, -2.0])])
    with pytest.raises(InvalidInputError, match="at least one contact"):
        zmp_from_wrenches([])
