"""Solo-12 trots on point feet with one inverse-dynamics controller whose contacts change.

:func:`taskspace.locomotion.trot`: diagonal pairs swing in turn; before each lift-off the pair's
contacts are removed with a transition (``remove_contact(frame, transition_time, dt)``: the
normal-force bound ramps to 0), at touchdown they are added back with their bound raised from
``min_force`` to the weight. Every phase is simulated by Pinocchio's constraint dynamics with
3-D point contacts at the stance feet. References, independent of the controller's paths:

* Pinocchio's RNEA with the contacts the controller reports active (world-aligned linear
  Jacobians of ``pin.getFrameJacobian``) equals the torques and is zero on the floating base;
* the simulator holds exactly the feet the controller has as contacts;
* the friction cones ``K f >= k`` of the QP's and the simulator's forces (minimum force 0
  while a foot is released, and below the ramp's bound);
* the CoM and swing-foot references, tracked within bounds over the whole trot; the CoM at the
  end above the feet's diagonals' crossing.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import InverseDynamicsQP, InverseDynamicsStatus
from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.locomotion import TrotOptions, quadruped_trot, trot

SWINGS = 4


class _Spy(InverseDynamicsQP):
    """Records every controller made and every step it solved."""

    made: ClassVar[list[_Spy]] = []

    def __init__(self, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        self.steps: list[tuple[np.ndarray, np.ndarray, object]] = []
        _Spy.made.append(self)

    def solve(self, state):  # type: ignore[no-untyped-def]
        res = super().solve(state)
        self.steps.append((state.q.copy(), state.v.copy(), res))
        return res


@pytest.fixture(scope="module")
def trotted(robot_loader):
    robot = robot_loader("solo12")
    _Spy.made = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(quadruped_trot, "InverseDynamicsQP", _Spy)
        res = trot(robot, SWINGS)
    return robot, res, list(_Spy.made)


@pytest.mark.slow
def test_solo12_trots_with_one_controller(trotted):
    robot, res, made = trotted
    assert res.success, res.message
    assert res.cone_violation <= 1e-6
    assert len(made) == 1
    qp = made[0]
    assert res.contact_changes == qp.contacts_version == 3 * 2 * SWINGS  # ramp, drop, add
    assert len(qp.steps) == len(res.times) and np.all(np.diff(res.times) > 1e-9)
    opts = TrotOptions()
    model, data = robot.model, robot.model.createData()
    contacts = {c.frame: c for c in qp.contacts}
    released = 0
    for k, (q, v, step) in enumerate(qp.steps):
        assert np.array_equal(q, res.q[k]) and np.array_equal(step.tau, res.tau[k])
        assert step.status is InverseDynamicsStatus.SOLVED
        held = {f for f in opts.feet if not res.swinging[f][k]}
        assert set(step.contacts) == held  # the simulator's contacts
        rhs = pin.rnea(model, data, q, v, step.a)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for frame in step.contacts:
            J = pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL_WORLD_ALIGNED)
            f = step.forces[frame]
            rhs -= J[:3].T @ f
            K, lo = contacts[frame].cone()
            for force in (f, res.forces[frame][k]):  # the QP's and the simulator's
                bound = lo.copy()
                if frame in step.releasing:
                    released += 1
                    bound[4] = 0.0  # minimum force 0 while released
                    assert force[2] <= step.releasing[frame] + 1e-6
                assert np.all(K @ force >= bound - 1e-6), (k, frame, (K @ force - bound).min())
        scale = np.abs(rhs).max()
        assert np.abs(rhs[:6]).max() <= 1e-6 * scale
        assert step.tau[6:] == pytest.approx(rhs[6:], abs=1e-6 * scale)
    ramp = round(opts.transition_time / opts.dt)
    assert released == 2 * 2 * SWINGS * ramp  # QP + simulator, two feet per swing


@pytest.mark.slow
def test_trot_tracks_its_com_and_feet(trotted):
    robot, res, _made = trotted
    opts = TrotOptions()
    assert np.abs(res.com - res.com_reference).max() < 0.005  # 3.3 mm measured
    # every foot moved SWINGS / 2 steps; the CoM ends above the crossing of the diagonals
    assert res.com[-1, 0] - res.com[0, 0] == pytest.approx(SWINGS / 2 * opts.step_length, abs=0.005)
    for frame in opts.feet:
        error = np.linalg.norm(res.feet[frame] - res.foot_reference[frame], axis=1)
        assert res.swinging[frame].sum() == 2 * round(opts.swing_time / opts.dt)
        assert error[res.swinging[frame]].max() < 0.003  # 0.95 mm measured
        assert error[~res.swinging[frame]].max() < 0.002
        p0 = robot.frame_placement(robot.q_default, frame).translation
        moved = [SWINGS / 2 * opts.step_length, 0.0, 0.0]
        assert res.feet[frame][-1] - p0 == pytest.approx(moved, abs=3e-3)


def test_trot_options_are_validated(robot_loader):
    for bad in (
        {"feet": ("FL_FOOT", "FL_FOOT", "HL_FOOT", "HR_FOOT")},
        {"dt": 0.0},
        {"transition_time": 0.5},
        {"friction": -1.0},
        {"feet": None},
        {"feet": ("a", "b", 3, "d")},
        {"qp": 1},
        {"dt": "x"},
    ):
        with pytest.raises(InvalidInputError):
            TrotOptions(**bad)  # type: ignore[arg-type]
    robot = robot_loader("solo12")
    with pytest.raises(InvalidInputError, match="n_swings"):
        trot(robot, 0)
    with pytest.raises(InvalidInputError):
        trot(robot, "2")  # type: ignore[arg-type]
    with pytest.raises(TaskspaceError):  # an unknown frame is named
        trot(robot, 2, TrotOptions(feet=("FL_FOOT", "FR_FOOT", "HL_FOOT", "nope")))
