import numpy as np
import pytest
from _curve_reference import integrate_car

from taskspace.errors import InvalidInputError, LimitError, PlanningError, UnknownNameError
from taskspace.planning.car import (
    CarModel,
    ControlSamplingOptions,
    grow_control_tree,
    lateral_velocity,
)
from taskspace.planning.kinodynamic_rrt import parking_lot
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.se2 import (
    angle_chord_distance,
    angle_distance,
    quaternion_distance,
    se2_distance,
    wrap_angle,
)


def test_exact_integration_matches_ode():
    m = CarModel(wheelbase=2.0, max_steering=0.5, max_speed=2.0)
    rng = np.random.default_rng(0)
    for _ in range(10):
        q = rng.uniform(-3, 3, 3)
        u = np.array([rng.uniform(-2, 2), rng.uniform(-0.5, 0.5)])
        tau = rng.uniform(0.1, 3.0)
        ref = integrate_car(q, [(u[0], u[1], tau)], 2.0)
        out = m.integrate(q, u, tau)
        assert np.allclose(out[:2], ref[:2], atol=1e-9)
        assert abs(wrap_angle(out[2] - ref[2])) < 1e-9


def test_dynamics_and_nonholonomic_constraint():
    m = CarModel()
    rng = np.random.default_rng(1)
    q = rng.uniform(-3, 3, (50, 3))
    u = np.stack([rng.uniform(-1, 1, 50), rng.uniform(-0.6, 0.6, 50)], 1)
    qd = m.dynamics(q, u)
    np.testing.assert_allclose(lateral_velocity(q, qd), 0.0, atol=1e-14)
    np.testing.assert_allclose(qd[:, 2], u[:, 0] * np.tan(u[:, 1]) / m.wheelbase)
    assert m.turning_radius == pytest.approx(2.5 / np.tan(0.6))
    # lateral motion violates the constraint
    assert abs(lateral_velocity([0, 0, 0], [0, 1, 0])) == 1.0


def test_se2_metrics_slide_3_58():
    assert angle_distance(0.1, 2 * np.pi - 0.1) == pytest.approx(0.2)
    assert angle_distance(np.pi, -np.pi) == pytest.approx(0.0, abs=1e-12)
    assert angle_chord_distance(0.0, np.pi) == pytest.approx(2.0)
    assert se2_distance([0, 0, 0], [3, 4, 0]) == pytest.approx(5.0)
    assert se2_distance([0, 0, 0], [0, 0, np.pi], rotation_weight=2.0) == pytest.approx(4.0)
    q = np.array([0.5, 0.5, 0.5, 0.5])
    assert quaternion_distance(q, -q) == 0.0
    with pytest.raises(InvalidInputError, match="r1 must be a unit quaternion"):
        quaternion_distance([1, 1, 0, 0], q)


def test_footprint_collision():
    m = CarModel(footprint_offsets=(0.0,), footprint_radius=1.0)
    w = PolygonWorld((Polygon.rectangle(3, -1, 4, 1),), (-10, -10, 10, 10))
    assert list(m.poses_free(w, [[1.9, 0, 0], [2.1, 0, 0], [0, 9.5, 0]])) == [True, False, False]


def test_control_based_sampling_tree_is_consistent():
    m = CarModel()
    world, start, _ = parking_lot()
    tree = grow_control_tree(
        m, world, start, options=ControlSamplingOptions(n_nodes=60), rng=np.random.default_rng(2)
    )
    assert tree.success and tree.nodes.shape == (61, 3)
    assert np.all(m.poses_free(world, tree.nodes))
    for i in range(1, 61):  # every node is its parent integrated with its control
        v, phi, tau = tree.controls[i]
        assert abs(phi) <= m.max_steering
        q = m.integrate(tree.nodes[tree.parents[i]], [v, phi], tau)
        assert np.allclose(q, tree.nodes[i])
    left = grow_control_tree(
        m, world, start, options=ControlSamplingOptions(n_nodes=20, steering="left_only")
    )
    assert np.all(left.controls[1:, 1] >= 0)


def test_errors():
    with pytest.raises(InvalidInputError, match=r"max_steering must be in \(0, pi/2\)"):
        CarModel(max_steering=2.0)
    with pytest.raises(LimitError, match=r"\|phi\| <= 0.6 rad"):
        CarModel().dynamics([0, 0, 0], [1.0, 0.9])
    world, start, _ = parking_lot()
    with pytest.raises(PlanningError, match=r"start pose .* is in collision"):
        grow_control_tree(CarModel(), world, [12, 2, 0])
    with pytest.raises(UnknownNameError, match="valid steerings are: both, left_only"):
        grow_control_tree(CarModel(), world, start, options=ControlSamplingOptions(steering="x"))
