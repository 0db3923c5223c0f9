"""``Robot.edit_model`` applies the massless-joint armature rule as loading does.

Issue #15 item 1. On load, a joint whose mass-matrix diagonal is zero at the default posture
gets an armature of 1 % of the smallest nonzero diagonal entry (``robot.py`` module docstring).
An edit that makes a joint massless (its bodies' inertias zero, or its armature set to zero)
must give the robot that loading the edited model gives, and an edit that gives the mass back
must drop the armature the rule added.

References: the rule computed here from Pinocchio's ``crba`` on a hand-edited copy of the model,
forward dynamics (``aba``) and the mass matrix of a robot loaded from the hand-edited model.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import ModelWarning
from taskspace.model import Robot

JOINT = "panda_joint7"  # carries only its own body (the hand and fingers are merged in)


@pytest.fixture(scope="module")
def loaded() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("panda")


def _robot(loaded: Robot, model: pin.Model | None = None) -> Robot:
    """A robot loaded from ``model`` (default: the panda's) at the panda's default posture."""
    return Robot(
        loaded.model if model is None else model,
        loaded.collision_model,
        loaded.visual_model,
        name="panda",
        default_configuration=loaded.q_default,
    )


def _massless(model: pin.Model) -> pin.Model:
    """The hand-edited model: the body of ``JOINT`` without inertia."""
    model = model.copy()
    model.inertias[model.getJointId(JOINT)] = pin.Inertia.Zero()
    return model


def _rule(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """The armature the rule gives ``model`` (computed here from Pinocchio's crba)."""
    diagonal = np.diag(pin.crba(model, model.createData(), q)).copy()
    empty = diagonal <= 1e-12 * max(float(diagonal.max()), 1.0)
    armature = np.asarray(model.armature, dtype=float).copy()
    armature[empty] = 0.01 * diagonal[~empty].min()
    return armature


def _same_robot(robot: Robot, reference: Robot) -> None:
    q, v, tau = robot.q_default, np.full(robot.nv, 0.3), np.linspace(-1.0, 1.0, robot.nv)
    assert robot.massless_joints == reference.massless_joints
    assert np.array_equal(robot._model.armature, reference._model.armature)
    assert np.array_equal(robot.model.armature, reference._model.armature)  # the public copy
    model, other = robot._model, reference._model
    a = pin.aba(model, model.createData(), q, v, tau)
    b = pin.aba(other, other.createData(), q, v, tau)
    assert np.all(np.isfinite(a))
    assert np.allclose(a, b, rtol=0, atol=1e-9)


def test_an_edit_that_makes_a_joint_massless_gives_it_the_rule_armature(loaded: Robot) -> None:
    robot = _robot(loaded)
    assert robot.massless_joints == ()
    expected = _rule(_massless(loaded.model), loaded.q_default)
    k = loaded.joint_v_index(JOINT)
    assert expected[k] > 0 and np.count_nonzero(expected) == 1  # the reference rule is real
    state = robot.state(robot.q_default)
    with pytest.warns(ModelWarning, match=JOINT):
        with robot.edit_model() as model:
            model.inertias[model.getJointId(JOINT)] = pin.Inertia.Zero()
    assert robot.massless_joints == (JOINT,)
    assert np.allclose(robot._model.armature, expected, rtol=1e-12, atol=0)
    with pytest.warns(ModelWarning, match=JOINT):
        reference = _robot(loaded, _massless(loaded.model))
    _same_robot(robot, reference)
    # a state made before follows (it is re-evaluated with the new values)
    state.update(robot.q_default)
    assert np.isfinite(np.asarray(state.data.oMi[7].translation)).all()


def test_an_edit_that_gives_the_mass_back_drops_the_rule_armature(loaded: Robot) -> None:
    with pytest.warns(ModelWarning, match=JOINT):
        robot = _robot(loaded, _massless(loaded.model))
    assert robot.massless_joints == (JOINT,)
    inertia = loaded.model.inertias[loaded.model.getJointId(JOINT)]
    with robot.edit_model() as model:  # the armature entry is left as the block shows it
        model.inertias[model.getJointId(JOINT)] = inertia
    assert robot.massless_joints == ()
    assert not np.any(robot._model.armature)
    _same_robot(robot, _robot(loaded))


def test_an_edit_that_zeroes_the_armature_of_a_massless_joint_gets_the_rule_again(
    loaded: Robot,
) -> None:
    with pytest.warns(ModelWarning, match=JOINT):
        robot = _robot(loaded, _massless(loaded.model))
    with pytest.warns(ModelWarning, match=JOINT):
        with robot.edit_model() as model:
            model.armature = np.zeros(robot.nv)
    with pytest.warns(ModelWarning, match=JOINT):
        reference = _robot(loaded, _massless(loaded.model))
    _same_robot(robot, reference)
    assert robot.massless_joints == (JOINT,)


def test_an_armature_set_by_the_edit_is_kept(loaded: Robot) -> None:
    with pytest.warns(ModelWarning, match=JOINT):
        robot = _robot(loaded, _massless(loaded.model))
    k = loaded.joint_v_index(JOINT)
    with robot.edit_model() as model:
        armature = np.asarray(model.armature).copy()
        armature[k] = 0.5
        model.armature = armature
    hand = _massless(loaded.model)
    hand.armature = armature
    _same_robot(robot, _robot(loaded, hand))  # no warning: the joint has a rotor inertia
    assert robot._model.armature[k] == 0.5 and robot.massless_joints == ()
    # and the mass given back later keeps the armature the edit set
    inertia = loaded.model.inertias[loaded.model.getJointId(JOINT)]
    with robot.edit_model() as model:
        model.inertias[model.getJointId(JOINT)] = inertia
    assert robot._model.armature[k] == 0.5
