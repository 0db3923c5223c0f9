"""``DifferentialIK.advance``'s armed kernel step (``WeightedIKKernel.arm`` / ``step``).

When every box is constant at a ``dt`` (``bounds_read_state = False``), the kernel keeps the
model, the tasks, the boxes and the damping, and the lean call passes only the state's data,
``q`` and ``dt``. References, independent of the kernel: quadprog's minimizer of the QP the
Python path builds at the state before each step, that QP's KKT residuals at the step
(multipliers recovered from stationarity), Pinocchio's ``integrate`` and a fresh
``pin.Data`` at the new configuration.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK
from taskspace.model import Robot, State
from taskspace.qp.kkt import box_kkt_residuals
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")

DT = 0.01


class SoftVelocityBox(JointVelocityLimits):
    """A soft, state-independent box: a fraction of the velocity limits (declared constant)."""

    hard_bounds = False
    bounds_read_state = False

    def bounds(self, state: State, dt: float) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[override]
        lb, ub = super().bounds(state, dt)
        return 0.6 * lb, 0.6 * ub


def _reference(ik: DifferentialIK, state: State, dt: float) -> np.ndarray:
    """quadprog's minimizer of the Python path's QP at ``state``."""
    p = ik.build(state, dt)
    n = p.n
    lo, hi = p.lb > -1e19, p.ub < 1e19
    C = np.hstack([np.eye(n)[lo].T, -np.eye(n)[hi].T])
    b = np.concatenate([p.lb[lo], -p.ub[hi]])
    return np.asarray(quadprog.solve_qp(p.H, -p.g, C, b, 0)[0])


def _assert_kinematics(robot: Robot, state: State) -> None:
    """The state's data equal Pinocchio's at (state.q, state.v), computed afresh."""
    model = robot.model
    ref = model.createData()
    if state.has_velocity:
        pin.forwardKinematics(model, ref, state.q, state.v, np.zeros(robot.nv))
        pin.computeJointJacobians(model, ref)
    else:
        pin.computeJointJacobians(model, ref, state.q)
    pin.updateFramePlacements(model, ref)
    data = state.data
    for f in range(model.nframes):
        np.testing.assert_allclose(data.oMf[f].homogeneous, ref.oMf[f].homogeneous, atol=1e-12)
    np.testing.assert_allclose(data.J, ref.J, atol=1e-12)
    if state.has_velocity:
        for j in range(model.njoints):
            np.testing.assert_allclose(data.v[j].vector, ref.v[j].vector, atol=1e-12)


def _random_stack(robot: Robot, rng: np.random.Generator) -> tuple[list[Task], list[Task]]:
    """Pose/position tasks on random frames, maybe the CoM, a posture; random weights, gains."""
    state = robot.state(robot.q_default)
    bodies = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    tasks = []
    for kind in rng.permutation(["pose", "position", "com", "pose"])[: rng.integers(2, 5)]:
        if kind == "com":
            task = Task(F.CenterOfMass(robot), weight=float(rng.uniform(0.1, 2)))
            task.set_target(state.com() + rng.uniform(-0.05, 0.05, 3))
        else:
            name = str(rng.choice(bodies))
            feature = F.FramePose(robot, name) if kind == "pose" else F.Position(robot, name)
            task = Task(feature, weight=float(rng.uniform(0.1, 2)), gain=float(rng.uniform(0.2, 1)))
            M = state.frame_placement(robot.frame_id(name))
            shift = pin.exp6(rng.uniform(-0.3, 0.3, 6))
            task.set_target(M * shift if kind == "pose" else (M * shift).translation)
        tasks.append(task)
    weight = float(rng.uniform(1e-4, 1e-2))
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=weight)
    return tasks, [*tasks, posture]


def _random_q(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    q = pin.integrate(robot.model, robot.q_default, 0.4 * rng.standard_normal(robot.nv))
    idx = robot.limited_joints_q
    q[idx] = np.clip(q[idx], robot.lower_limits[idx] + 0.01, robot.upper_limits[idx] - 0.01)
    return q


def _moving_targets(tasks: list[Task], rng: np.random.Generator) -> None:
    """Move every non-posture task's target a little (the kernel reads them at each call)."""
    for task in tasks:
        T = task.target
        if isinstance(T, pin.SE3):
            task.set_target(T * pin.exp6(rng.uniform(-0.05, 0.05, 6)))
        else:
            task.set_target(np.asarray(T) + rng.uniform(-0.02, 0.02, 3))


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_armed_steps_match_quadprog_kkt_and_pinocchio(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random stacks, states (with and without velocity) and boxes (hard and soft)."""
    made = _count_fast(monkeypatch)
    robot = load_robot(name)
    rng = np.random.default_rng(11)
    armed = constrained = 0
    for trial in range(4):
        moving, tasks = _random_stack(robot, rng)
        boxes = [JointPositionLimits(robot), JointVelocityLimits(robot)]
        if trial % 2:
            boxes.append(SoftVelocityBox(robot))
        ik = DifferentialIK(robot, tasks, boxes)
        assert ik.native
        q = _random_q(robot, rng)
        v = 0.1 * rng.standard_normal(robot.nv)
        state = robot.state(q, v) if trial >= 2 else robot.state(q)
        for _ in range(6):
            _moving_targets(moving, rng)
            before = robot.state(state.q, state.v) if state.has_velocity else robot.state(state.q)
            x = _reference(ik, before, DT)
            was_armed = ik._lean_step is not None and ik._lean_dt == DT
            result = ik.advance(state, DT)
            armed += was_armed
            assert result.success and result.qp.backend == "native"
            constrained += result.qp.status.name != "UNCONSTRAINED"
            np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
            kkt = box_kkt_residuals(ik.build(before, DT), result.dq)
            assert kkt.primal < 1e-9 and kkt.dual < 1e-8 and kkt.complementarity < 1e-9
            expected = pin.integrate(robot.model, before.q, result.dq)
            np.testing.assert_allclose(state.q, expected, atol=1e-14, rtol=0)
            assert state.has_velocity == (trial >= 2)
            if state.has_velocity:
                np.testing.assert_allclose(state.v, result.dq / DT, atol=1e-14, rtol=0)
            _assert_kinematics(robot, state)
            # the new q (and v) are read-only for good, and nobody else's
            for a in (state.q, state.v) if state.has_velocity else (state.q,):
                assert not a.flags.writeable
                with pytest.raises(ValueError):
                    a.setflags(write=True)
            assert result.dq.flags.writeable and not np.shares_memory(result.dq, state.q)
    assert armed == 4 * 5  # every step after the first ran the armed kernel step
    assert sum(c.taken for c in made) == 4 * 5  # as one C call (arm_advance)
    assert constrained > 0


def test_armed_step_is_renewed_after_dt_assignments_and_the_robot_version() -> None:
    """Each key of the arming (dt, a task assignment, Robot.version) re-arms the kernel."""
    robot = Robot.load("panda")  # its own: set_limits below
    rng = np.random.default_rng(5)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng))

    def step(dt: float = DT) -> None:
        x = _reference(ik, robot.state(state.q), dt)
        result = ik.advance(state, dt)
        np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)

    step()
    step()
    first = ik._lean_step
    assert first is not None
    step(0.05)  # another dt: the velocity box is 5x wider
    step(0.05)
    step(0.002)  # and narrower (active)
    step(0.002)
    moving[0].weight = 5.0  # an assignment: the weights are sent again, the kernel re-armed
    step(0.002)
    step(0.002)
    slow = 0.05 * robot.velocity_limits
    robot.set_limits(velocity=slow)  # a new version: a new box
    step(0.002)
    dq = ik.advance(state, 0.002).dq
    assert np.all(np.abs(dq) <= slow * 0.002 + 1e-12) and np.isclose(np.abs(dq / slow).max(), 0.002)
    # a target changed in place between armed steps is read (the kernel keeps the task)
    moving[0].set_target(moving[0].target)  # type: ignore[arg-type]
    step(0.002)


def test_disarmed_kernel_refuses_the_armed_step() -> None:
    robot = load_robot("panda")
    rng = np.random.default_rng(2)
    _, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(robot.q_default)
    ik.advance(state, DT)
    kernel = ik._native.kernel  # type: ignore[union-attr]
    kernel.disarm()
    with pytest.raises(InvalidInputError):
        kernel.step(state._data, state._q, 0.0)


# ---------------------------------------------------------------- the armed advance in one C call
# (NativeWeightedStack.arm_advance: lock, gate, step, the state's new q and v, the result)


class _Counted:
    """Wraps the armed C advance and counts the steps it took (a result, not None/False)."""

    def __init__(self, fast: object) -> None:
        self.fast = fast
        self.taken = 0

    def __call__(self, state: State, dt: float) -> object:
        out = self.fast(state, dt)  # type: ignore[operator]
        self.taken += bool(out)
        return out


def _count_fast(monkeypatch: pytest.MonkeyPatch) -> list[_Counted]:
    """Every armed C advance made from now on, wrapped (see :class:`_Counted`)."""
    from taskspace.ik._native_stack import NativeWeightedStack

    made: list[_Counted] = []
    original = NativeWeightedStack.arm_advance

    def arm_advance(self: NativeWeightedStack, *args: object) -> object:
        fast = original(self, *args)  # type: ignore[arg-type]
        if fast is None:
            return None
        made.append(_Counted(fast))
        return made[-1]

    monkeypatch.setattr(NativeWeightedStack, "arm_advance", arm_advance)
    return made


def _snapshot(result: object) -> dict[str, object]:
    """The values of every field of a result, copied (read through the public API)."""
    qp = result.qp  # type: ignore[attr-defined]
    return {
        "success": result.success,  # type: ignore[attr-defined]
        "status": result.status,  # type: ignore[attr-defined]
        "dq": np.array(result.dq),  # type: ignore[attr-defined]
        "velocity": np.array(result.velocity),  # type: ignore[attr-defined]
        "culprits": list(result.culprits),  # type: ignore[attr-defined]
        "build_time": result.build_time,  # type: ignore[attr-defined]
        "solve_time": result.solve_time,  # type: ignore[attr-defined]
        "qp": (qp.success, qp.status, np.array(qp.x), qp.objective, qp.iterations, qp.backend),
    }


def _assert_same(a: dict[str, object], b: dict[str, object]) -> None:
    for key in a:
        if key in ("dq", "velocity"):
            np.testing.assert_array_equal(a[key], b[key])  # type: ignore[arg-type]
        elif key == "qp":
            for x, y in zip(a[key], b[key]):  # type: ignore[call-overload]
                if isinstance(x, np.ndarray):
                    np.testing.assert_array_equal(x, y)
                else:
                    assert x == y, (key, x, y)
        else:
            assert a[key] == b[key], (key, a[key], b[key])


def test_adopt_resets_lists_what_adopt_does() -> None:
    """ADOPT_RESETS (what the C advance does to a state) equals what State._adopt does."""
    from taskspace.model.state import ADOPT_RESETS

    robot = load_robot("panda")
    state = robot.state(robot.q_default)
    slots = [n for n in State.__slots__ if n != "__weakref__"]  # the weak-reference slot
    marks = {name: {"mark": name} for name in slots}
    for name, mark in marks.items():
        setattr(state, name, mark)
    q = np.zeros(robot.nq)
    state._adopt(q, None, True)
    changed = {n for n in slots if getattr(state, n) is not marks[n] or not marks[n]}
    none, cleared, false = ADOPT_RESETS
    assert changed == {"_q", "_v", "_has_velocity", *none, *cleared, *false}
    assert all(getattr(state, n) is None for n in none)
    assert all(getattr(state, n) is marks[n] and not marks[n] for n in cleared)  # emptied
    assert all(getattr(state, n) is False for n in false)


@pytest.mark.parametrize("velocity", [False, True])
def test_armed_advance_leaves_the_state_as_update_does(
    velocity: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every slot of a state moved by the C advance equals that of a state updated by Python."""
    made = _count_fast(monkeypatch)
    robot = load_robot("panda")
    rng = np.random.default_rng(3)
    _, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    q = _random_q(robot, rng)
    state = robot.state(q, 0.1 * np.ones(robot.nv)) if velocity else robot.state(q)
    ik.advance(state, DT)  # arms
    tcp = robot.frame_id("panda_hand_tcp")
    for _ in range(3):
        # fill the caches the step must mark stale
        for s in (state, ref := robot.state(state.q, state.v if velocity else None)):
            s.com(), s.com_jacobian()
            s.compute_distances()
            if velocity:
                s.com_drift()
            s.frame_jacobian(tcp), s.frame_jacobian_local(tcp)
        result = ik.advance(state, DT)
        ref.update(
            pin.integrate(robot.model, ref.q, result.dq), result.dq / DT if velocity else None
        )
        for name in State.__slots__:
            a, b = getattr(state, name), getattr(ref, name)
            if isinstance(a, np.ndarray):
                np.testing.assert_allclose(a, b, atol=1e-14, rtol=0, err_msg=name)
                assert a.flags.writeable == b.flags.writeable, name
            elif isinstance(a, dict):
                assert a.keys() == b.keys(), name
            elif a is None or isinstance(a, (bool, int, float)):
                assert a == b, (name, a, b)
        assert state._v is state._a0 or velocity
        _assert_kinematics(robot, state)
        np.testing.assert_allclose(state.com(), ref.com(), atol=1e-14, rtol=0)
        np.testing.assert_allclose(
            [r.min_distance for r in state.distance_results()],
            [r.min_distance for r in ref.distance_results()],
            atol=1e-12,
            rtol=0,
        )
    assert made and made[-1].taken == 3


def test_armed_advance_results_are_kept_and_lazy_fields_equal_eager_ones(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each result is its own: its fields (and the lazy velocity and qp, read now or later)
    never change after later steps; culprits is a new list; qp equals the eager QPResult."""
    made = _count_fast(monkeypatch)
    robot = load_robot("panda")
    rng = np.random.default_rng(8)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng))
    ik.advance(state, DT)
    kept, read_late = [], []
    for k in range(8):
        _moving_targets(moving, rng)
        before = robot.state(state.q)
        x = _reference(ik, before, DT)
        result = ik.advance(state, DT)
        np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
        assert result.native_declined == ""
        if k % 2:  # read now: equals the eager computation
            np.testing.assert_array_equal(result.velocity, result.dq / DT)
            qp = result.qp
            assert qp.success and qp.backend == "native" and qp.x is result.dq
            assert qp.status.name in ("SOLVED", "UNCONSTRAINED") and qp.iterations >= 0
            p, dq = ik.build(before, DT), result.dq
            assert np.isclose(qp.objective, 0.5 * dq @ p.H @ dq + p.g @ dq, rtol=1e-9, atol=1e-14)
            assert result.build_time >= 0 and result.solve_time >= 0 and qp.solve_time >= 0
            kept.append((result, _snapshot(result)))
        else:  # read only after later steps
            read_late.append((result, np.array(result.dq), x))
        assert result.culprits == [] and result.success and result.status.name == "SOLVED"
    results = [r for r, _ in kept] + [r for r, _, _ in read_late]
    assert len({id(r.culprits) for r in results}) == len(results)  # a new list each
    kept[0][0].culprits.append("mine")  # changes that result only
    assert all(r.culprits == [] for r in results[1:])
    kept[0][0].culprits.clear()
    for result, snap in kept:
        _assert_same(_snapshot(result), snap)
    for result, dq, x in read_late:
        np.testing.assert_array_equal(result.dq, dq)
        np.testing.assert_array_equal(result.velocity, dq / DT)
        assert result.qp.x is result.dq
        np.testing.assert_allclose(result.qp.x, x, atol=1e-8, rtol=0)
    for a in results:
        assert not np.shares_memory(a.dq, state.q)
        assert sum(np.shares_memory(a.dq, b.dq) for b in results) == 1
    assert made and made[-1].taken == 8


def test_armed_advance_reuses_only_arrays_nobody_sees(monkeypatch: pytest.MonkeyPatch) -> None:
    """The C advance reuses the arrays of a step two calls ago only when nobody holds them: a
    slice of an old q, an old dq held by a weak reference only, keep their values."""
    import weakref

    made = _count_fast(monkeypatch)
    robot = load_robot("panda")
    rng = np.random.default_rng(9)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng), 0.1 * np.ones(robot.nv))
    ik.advance(state, DT)
    ids = set()
    for _ in range(6):  # results dropped at once: their arrays are reused
        _moving_targets(moving, rng)
        ids.add(id(ik.advance(state, DT).dq))
    assert len(ids) <= 3  # (the addresses of a new array could repeat too; see below)
    _moving_targets(moving, rng)
    result = ik.advance(state, DT)
    dq, q_slice, v_slice = result.dq.copy(), state.q[2:5], state.v[1:4]
    q_values, v_values = q_slice.copy(), v_slice.copy()
    weak = weakref.ref(result.dq)
    del result
    for _ in range(6):
        _moving_targets(moving, rng)
        before = robot.state(state.q, state.v)
        x = _reference(ik, before, DT)
        np.testing.assert_allclose(ik.advance(state, DT).dq, x, atol=1e-8, rtol=0)
        np.testing.assert_allclose(state.v, x / DT, atol=1e-14, rtol=0)
        kept = weak()  # never reused: alive with its values, or let go
        if kept is not None:
            np.testing.assert_array_equal(kept, dq)
        del kept
    np.testing.assert_array_equal(q_slice, q_values)
    np.testing.assert_array_equal(v_slice, v_values)
    assert made and made[-1].taken == 13


def test_armed_advance_gate_and_lock(monkeypatch: pytest.MonkeyPatch) -> None:
    """The C advance does nothing (None) when the solver's lock is held or a key differs."""
    robot = load_robot("panda")
    rng = np.random.default_rng(4)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng))
    ik.advance(state, DT)
    fast = ik._lean_fast
    assert fast is not None
    q = state.q

    class MyState(State):
        __slots__ = ()

    other = robot.state(state.q)
    mine = MyState(robot, state.q)
    with ik._lock:  # another thread's step: nothing done, the caller waits on the lock
        assert fast(state, DT) is None
    assert fast(state, 0.02) is None  # another dt
    assert fast(state, np.float64(DT)) is None  # not a float: the checked path
    assert fast(mine, DT) is None  # a subclass of State
    assert fast(load_robot("ur5").state(load_robot("ur5").q_default), DT) is None
    assert state.q is q and not ik._lock.locked()
    assert fast(other, DT)  # a state of this robot: taken
    moving[0].weight = 2.0  # an assignment
    assert fast(state, DT) is None
    ik.advance(state, DT)  # re-arms
    assert ik._lean_fast(state, DT)
    with pytest.raises(TypeError):
        fast(state)
    assert not ik._lock.locked()


def test_armed_advance_error_releases_the_lock() -> None:
    """A target the kernel cannot read: the error names the task, the lock is free, the state
    has not moved, and the next step works."""
    robot = load_robot("panda")
    rng = np.random.default_rng(6)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng))
    ik.advance(state, DT)
    assert ik._lean_fast is not None
    q = state.q
    target = moving[0].target
    object.__setattr__(moving[0], "_target", None)
    with pytest.raises(InvalidInputError, match=re.escape(moving[0].name)):
        ik.advance(state, DT)
    assert not ik._lock.locked() and state.q is q
    object.__setattr__(moving[0], "_target", target)
    x = _reference(ik, robot.state(state.q), DT)
    np.testing.assert_allclose(ik.advance(state, DT).dq, x, atol=1e-8, rtol=0)
