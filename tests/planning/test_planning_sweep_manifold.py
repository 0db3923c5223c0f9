"""JointManifold on a bare model's default limits and on unnormalized rotations (sweep 35).

A joint added to a bare ``pinocchio.Model`` has the limits -+1.8e308: the manifold accepted
them and ``sample`` raised numpy's bare OverflowError. ``difference`` (so ``distances``, the
planners' metric) scaled a planar or floating base's translation by the norm of its
(cos, sin) pair or quaternion; Pinocchio reads those as directions.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning import ConfigurationSpace, FunctionChecker
from taskspace.planning.joint_manifold import JointManifold


def _model(root: object) -> pin.Model:
    model = pin.Model()
    base = model.addJoint(0, root, pin.SE3.Identity(), "base")
    arm = model.addJoint(base, pin.JointModelRY(), pin.SE3.Identity(), "arm")
    model.appendBodyToJoint(arm, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    return model


def test_default_limits_of_a_bare_model_are_refused_by_name() -> None:
    model = _model(pin.JointModelPlanar())
    assert model.upperPositionLimit[-1] > 1e308  # Pinocchio's default
    with pytest.raises(InvalidInputError, match="'arm' has no finite position limits"):
        JointManifold(model, base_lower=[-1, -1], base_upper=[1, 1])
    model.lowerPositionLimit[-1], model.upperPositionLimit[-1] = -2.0, 2.0
    manifold = JointManifold(model, base_lower=[-1, -1], base_upper=[1, 1])
    q = manifold.sample(np.random.default_rng(0), 5)
    assert np.all(np.abs(q[:, -1]) <= 2.0)


@pytest.mark.parametrize(
    ("root", "box", "rot"),
    [(pin.JointModelPlanar(), 2, slice(2, 4)), (pin.JointModelFreeFlyer(), 3, slice(3, 7))],
    ids=["planar", "free_flyer"],
)
def test_difference_reads_rotations_as_directions(root: object, box: int, rot: slice) -> None:
    model = _model(root)
    model.lowerPositionLimit[-1], model.upperPositionLimit[-1] = -2.0, 2.0
    manifold = JointManifold(model, base_lower=[-3] * box, base_upper=[3] * box)
    rng = np.random.default_rng(4)
    q0, q1 = manifold.sample(rng, 20), manifold.sample(rng, 20)
    reference = np.array([pin.difference(model, a, b) for a, b in zip(q0, q1)])
    np.testing.assert_allclose(manifold.difference(q0, q1), reference, atol=1e-9)
    scaled0, scaled1 = q0.copy(), q1.copy()
    scaled0[:, rot] *= 1.7  # off the unit circle / sphere
    scaled1[:, rot] *= 0.6
    np.testing.assert_allclose(manifold.difference(scaled0, scaled1), reference, atol=1e-9)
    np.testing.assert_allclose(
        manifold.distances(scaled0, scaled1), np.linalg.norm(reference, axis=1), atol=1e-9
    )


def _wall_space(weights: list[float]) -> ConfigurationSpace:
    model = pin.Model()
    j1 = model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "a")
    model.addJoint(j1, pin.JointModelRY(), pin.SE3.Identity(), "b")
    model.lowerPositionLimit[:] = -1.0
    model.upperPositionLimit[:] = 1.0
    manifold = JointManifold(model, weights=weights)
    # a wall 0.02 rad thick at q[0] = 0.3 (exact: the reference is the predicate itself)
    checker = FunctionChecker(lambda Q: np.abs(Q[:, 0] - 0.3) > 0.01)
    return ConfigurationSpace(manifold.lower, manifold.upper, checker, manifold=manifold)


def test_small_metric_weights_do_not_coarsen_the_edge_checks() -> None:
    space = _wall_space([0.05, 0.05])
    # the edge's weighted length is 0.05: checked at resolution 0.03 of the metric it was cut
    # in 2, its only interior point at q[0] = 0.5, and the wall at 0.3 was crossed unseen
    assert not space.motion_valid(np.zeros(2), np.array([1.0, 0.0]))
    assert not space.path_valid([[0.0, 0.0], [1.0, 0.0]])
    assert space.motion_valid(np.zeros(2), np.array([0.25, 0.0]))
    assert space.edge_resolution == pytest.approx(0.03 * 0.05)
    # weights >= 1 keep the metric resolution as it was
    assert _wall_space([1.0, 2.0]).edge_resolution == 0.03
