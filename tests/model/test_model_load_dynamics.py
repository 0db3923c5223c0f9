"""Loading for dynamics: ``geometry=False`` and joints that move no mass.

``Robot.load(name, geometry=False)`` gives the same kinematic and dynamic model without
meshes. A joint whose mass-matrix diagonal is zero (romeo's fingers: massless bodies) would
make forward dynamics NaN; it gets a small armature with a ``ModelWarning``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, ModelWarning
from taskspace.model import Robot
from tests.conftest import load_robot


def test_without_geometry_the_model_is_the_same() -> None:
    full = load_robot("solo12")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bare = Robot.load("solo12", geometry=False)
    assert full.collision_model.ngeoms > 0 and full.visual_model.ngeoms > 0
    assert bare.collision_model.ngeoms == 0 and bare.visual_model.ngeoms == 0
    assert bare.collision_pairs == []
    assert bare.frame_names == full.frame_names
    np.testing.assert_array_equal(bare.q_default, full.q_default)
    np.testing.assert_array_equal(bare.effort_limits, full.effort_limits)
    q = full.random_configuration(np.random.default_rng(0))
    M_full = pin.crba(full.model, full.model.createData(), q)
    M_bare = pin.crba(bare.model, bare.model.createData(), q)
    np.testing.assert_allclose(M_bare, M_full, rtol=0, atol=0)


@pytest.mark.parametrize("value", [0, 1, "no", None])
def test_geometry_flag_is_a_bool(value: object) -> None:
    with pytest.raises(InvalidInputError, match="geometry must be True or False"):
        Robot.load("solo12", geometry=value)  # type: ignore[arg-type]


def test_joints_that_move_no_mass_get_an_armature() -> None:
    with pytest.warns(ModelWarning, match="move no mass"):
        robot = Robot.load("romeo", geometry=False)
    assert len(robot.massless_joints) == 24
    assert {"LHand", "RThumb3"} <= set(robot.massless_joints)
    model = robot.model
    q, v, tau = robot.q_default, np.zeros(robot.nv), np.zeros(robot.nv)
    # the reference: the same model without the armature has a singular mass matrix
    raw = pin.Model(model)
    raw.armature = np.zeros(robot.nv)
    M_raw = pin.crba(raw, raw.createData(), q)
    empty = np.flatnonzero(np.diag(M_raw) == 0.0)
    assert empty.size == 24
    assert np.linalg.matrix_rank(M_raw + np.triu(M_raw, 1).T) < robot.nv
    # with it, forward dynamics is defined and inverts inverse dynamics
    a = pin.aba(model, model.createData(), q, v, tau)
    assert np.all(np.isfinite(a))
    np.testing.assert_allclose(
        pin.rnea(model, model.createData(), q, v, a), tau, atol=1e-8 * robot.mass * 9.81
    )
    armature = np.asarray(model.armature)
    assert np.all(armature[empty] > 0) and np.all(np.delete(armature, empty) == 0)
    diagonal = np.diag(M_raw)
    assert armature[empty][0] == pytest.approx(0.01 * diagonal[diagonal > 0].min())


def test_robots_with_mass_everywhere_are_unchanged() -> None:
    robot = load_robot("talos")
    assert robot.massless_joints == ()
    assert not np.any(np.asarray(robot.model.armature))
