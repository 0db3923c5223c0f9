"""Every legged robot of example-robot-data stands 2 s under the inverse-dynamics QP.

For each legged robot: loaded by name (kinematics and dynamics only), a CoM task (``kp = 10``)
and a posture task on the whole configuration, contacts as its feet are (point contacts with
friction cones for point feet, 6-D contacts with cones and a centre-of-pressure rectangle for
flat feet); simulated 2 s by Pinocchio's constraint dynamics (``simulate_with_contacts``).
Checked at every step: the QP step succeeds, the simulated contact forces stay inside their
cones; over the run: the feet carry the robot's weight (Pinocchio's total mass), the CoM stays
within 5 mm of its start and the robot ends at rest.

The feet come from a small table (``LEGGED``), itself checked against the model: the listed
feet sit on the lowest joints of the default posture, one foot per such joint, none missing.
Every floating-base robot of example-robot-data is in exactly one of ``LEGGED``,
``CANNOT_STAND`` (with the reason, itself checked) and ``NOT_LEGGED`` (with what it is), so a
robot added to example-robot-data cannot be skipped silently.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
import pytest
from example_robot_data.robots_loader import ROBOTS

from taskspace import ModelLoadError
from taskspace import features as F
from taskspace.constraints import Contact6D, PointContact
from taskspace.constraints.contact import Contact
from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
from taskspace.control.inverse_dynamics_qp_rollout import ContactRollout, simulate_with_contacts
from taskspace.model import Robot
from taskspace.tasks import Task

pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore")]

DURATION = 2.0  # [s]
DT = 0.004  # [s]
FRICTION = 0.6
# A conservative sole (10 cm x 6 cm), smaller than every flat foot below: the centre of
# pressure constraint is then stricter than the real foot's.
HALF_LENGTH, HALF_WIDTH = 0.05, 0.03


@dataclass(frozen=True)
class Legged:
    """How a robot stands.

    Attributes:
        feet: foot frames.
        point: point feet (3-D contacts) or flat feet (6-D contacts).
        posture: joint values [rad] replacing the default posture's (a shipped posture that
            is not a standing one).
        flat_soles: add, on each foot's joint, a frame at the foot frame's origin whose axes
            are the world's at the default posture (the model has no frame with its z axis
            normal to the sole).
    """

    feet: tuple[str, ...]
    point: bool
    posture: dict[str, float] = field(default_factory=dict)
    flat_soles: bool = False


UNITREE = ("FL_foot", "FR_foot", "RL_foot", "RR_foot")
ODRI = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
ANYMAL = ("LF_FOOT", "LH_FOOT", "RF_FOOT", "RH_FOOT")
TALOS = ("left_sole_link", "right_sole_link")
G1 = ("left_ankle_roll_link", "right_ankle_roll_link")
ICUB = ("l_sole", "r_sole")

LEGGED: dict[str, Legged] = {
    # quadrupeds: point feet
    "solo8": Legged(ODRI, True),
    "solo12": Legged(ODRI, True),
    "quadruped": Legged(("BL_END", "BR_END", "FL_END", "FR_END"), True),
    "go1": Legged(UNITREE, True),
    "go2": Legged(UNITREE, True),
    "a1": Legged(UNITREE, True),
    "b1": Legged(UNITREE, True),
    "b1_z1": Legged(UNITREE, True),
    "laikago": Legged(UNITREE, True),
    "anymal": Legged(ANYMAL, True),
    "anymal_c": Legged(ANYMAL, True),
    "anymal_kinova": Legged(ANYMAL, True),
    "hyq": Legged(("lf_foot", "lh_foot", "rf_foot", "rh_foot"), True),
    # wheeled legs: the wheel's ground contact point
    "centauro": Legged(("contact_1", "contact_2", "contact_3", "contact_4"), True),
    # humanoids: flat feet
    "talos": Legged(TALOS, False),
    "talos_box": Legged(TALOS, False),
    "talos_legs": Legged(TALOS, False),
    "talos_full": Legged(TALOS, False),
    "talos_full_box": Legged(TALOS, False),
    "g1": Legged(G1, False),
    "g1_with_hands": Legged(G1, False),
    "icub": Legged(ICUB, False),
    "icub_reduced": Legged(ICUB, False),
    "romeo": Legged(("l_sole", "r_sole"), False),  # massless fingers: armature (ModelWarning)
    "alexander": Legged(("LEFT_FOOT", "RIGHT_FOOT"), False),
    # the foot frames' z axes are horizontal (y-up convention of the biomechanics model)
    "human": Legged(("left_foot", "right_foot"), False, flat_soles=True),
}

CANNOT_STAND = {
    # Two point feet: the support is a line, the roll about it is unactuated; a CoM and
    # posture task solved one step at a time cannot balance that inverted pendulum (checked
    # below: the CoM leaves its start by more than 1 cm within 0.5 s).
    "bolt": "two point feet (line support)",
    # Pinocchio's test humanoid: the shipped half-sitting posture has its feet tilted by 14 and
    # 24 degrees, and flat feet (ankle pitch = -(hip pitch + knee), -0.25..-0.42 rad) are
    # outside the ankle range [0, 2.618] (checked below). The inverse-dynamics QP is then
    # infeasible (joint-limit bounds) on flat feet.
    "simple_humanoid": "no standing posture within the joint limits",
    "simple_humanoid_classical": "no standing posture within the joint limits",
    # Not loadable here (checked: clear ModelLoadError).
    "cassie": "SDF model, this Pinocchio has no SDF parser",
}

NOT_LEGGED = {
    "hector": "quadrotor",
    "iris": "quadrotor",
    "hextilt": "hexarotor",
    "borinot": "flying arm",
    "falcon_bravo7_no_ee": "underwater vehicle with an arm",
    "falcon_bravo7_gripper": "underwater vehicle with an arm",
    "bluevolta_bravo7_no_ee": "underwater vehicle with an arm",
    "bluevolta_bravo7_gripper": "underwater vehicle with an arm",
    "pr2": "wheeled mobile manipulator",
    "so100": "table-top arm (free-flyer root in example-robot-data)",
    "so101": "table-top arm (free-flyer root in example-robot-data)",
}

_ROBOTS: dict[str, Robot] = {}


def _with_flat_soles(robot: Robot, feet: tuple[str, ...]) -> tuple[Robot, tuple[str, ...]]:
    """A copy of ``robot`` with a frame ``<foot>_flat_sole`` per foot (see ``Legged``)."""
    model = pin.Model(robot.model)
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_default)
    names = []
    for foot in feet:
        fid = model.getFrameId(foot)
        frame = model.frames[fid]
        placement = frame.placement * pin.SE3(data.oMf[fid].rotation.T, np.zeros(3))
        name = f"{foot}_flat_sole"
        model.addFrame(pin.Frame(name, frame.parentJoint, fid, placement, pin.FrameType.OP_FRAME))
        names.append(name)
    copy = Robot(
        model,
        robot.collision_model,
        robot.visual_model,
        name=robot.name,
        default_configuration=robot.q_default,
    )
    return copy, tuple(names)


def _load(name: str) -> Robot:
    if name not in _ROBOTS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _ROBOTS[name] = Robot.load(name, geometry=False)
    return _ROBOTS[name]


def _standing_posture(robot: Robot, legged: Legged) -> np.ndarray:
    q = robot.q_default.copy()
    for joint, value in legged.posture.items():
        q[robot.model.joints[robot.joint_id(joint)].idx_q] = value
    return q


def _lowest_joints(robot: Robot, q: np.ndarray, tolerance: float = 0.03) -> set[str]:
    """Joints carrying the lowest frames (within ``tolerance`` [m]), deepest of each chain."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    height: dict[int, float] = {}
    for i, frame in enumerate(model.frames):
        if frame.parentJoint > 0:
            z = float(data.oMf[i].translation[2])
            height[frame.parentJoint] = min(z, height.get(frame.parentJoint, np.inf))
    lowest = min(height.values())
    low = {j for j, z in height.items() if z <= lowest + tolerance}

    def ancestors(j: int) -> set[int]:
        out = set()
        while j > 0:
            j = model.parents[j]
            out.add(j)
        return out

    covered = set().union(*(ancestors(j) for j in low))
    return {str(model.names[j]) for j in low - covered}


def _stand(
    robot: Robot, legged: Legged, duration: float
) -> tuple[ContactRollout, list[Contact], np.ndarray, list[str]]:
    feet = legged.feet
    if legged.flat_soles:
        robot, feet = _with_flat_soles(robot, feet)
    q0 = _standing_posture(robot, legged)
    s = robot.state(q0, np.zeros(robot.nv))
    contacts: list[Contact] = [
        PointContact(robot, f, friction=FRICTION)
        if legged.point
        else Contact6D(robot, f, half_length=HALF_LENGTH, half_width=HALF_WIDTH, friction=FRICTION)
        for f in feet
    ]
    com = Task(F.CenterOfMass(robot), kp=10.0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), q0, weight=1e-2, kp=10.0)
    ctrl = InverseDynamicsQP(robot, [com, posture], contacts)
    failures: list[str] = []

    def controller(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        s.update(q, v)
        res = ctrl.solve(s)
        if not res.success:
            failures.append(f"t={t:.3f}: {res.status.name}")
        return res.tau

    roll = simulate_with_contacts(robot, controller, q0, np.zeros(robot.nv), duration, DT, contacts)
    return roll, contacts, np.asarray(com.target).copy(), failures


@pytest.mark.parametrize("name", sorted(LEGGED))
def test_legged_robot_stands_two_seconds_inside_its_cones(name: str) -> None:
    robot = _load(name)
    legged = LEGGED[name]
    # the table's feet are the model's lowest joints, one foot each, none missing
    q0 = _standing_posture(robot, legged)
    foot_joints = [
        str(robot.model.names[robot.model.frames[robot.frame_id(f)].parentJoint])
        for f in legged.feet
    ]
    assert sorted(foot_joints) == sorted(_lowest_joints(robot, q0)), foot_joints
    if not legged.point:  # flat feet: the contact frame's z axis is the ground normal
        check, feet = (
            _with_flat_soles(robot, legged.feet) if legged.flat_soles else (robot, legged.feet)
        )
        for f in feet:
            z_axis = check.frame_placement(q0, f).rotation[:, 2]
            assert z_axis[2] > np.cos(np.radians(5.0)), (f, z_axis)  # icub: 3.4 degrees

    roll, contacts, c0, failures = _stand(robot, legged, DURATION)
    assert not failures, failures[:5]
    assert roll.inside_cones, roll.cone_violations
    assert set(roll.cone_violations) == {c.frame for c in contacts}
    weight = pin.computeTotalMass(robot.model) * 9.81
    vertical = sum(roll.forces[c.frame][:, 2] for c in contacts)
    np.testing.assert_allclose(vertical, weight, rtol=1e-2)
    assert np.linalg.norm(roll.com - c0, axis=1).max() < 5e-3
    assert np.abs(roll.v[-1]).max() < 1e-3


def test_two_point_feet_cannot_stand() -> None:
    """bolt (CANNOT_STAND): the same controller lets its CoM leave by more than 1 cm in 0.5 s."""
    robot = _load("bolt")
    legged = Legged(("FL_FOOT", "FR_FOOT"), True)
    assert sorted(_lowest_joints(robot, robot.q_default)) == ["FL_KFE", "FR_KFE"]
    roll, _, c0, _ = _stand(robot, legged, 0.5)
    assert np.linalg.norm(roll.com - c0, axis=1).max() > 1e-2


@pytest.mark.parametrize("name", ["simple_humanoid", "simple_humanoid_classical"])
def test_no_standing_posture_within_the_limits(name: str) -> None:
    """simple_humanoid (CANNOT_STAND): tilted feet, and flat feet outside the ankle range."""
    robot = _load(name)
    q = robot.q_default.copy()
    for side in ("L", "R"):
        foot = robot.frame_placement(q, f"{side.lower()}_ankle")
        assert foot.rotation[2, 2] < np.cos(np.radians(10.0))  # tilted by more than 10 degrees
        pitch = {
            j: robot.model.joints[robot.joint_id(f"{side}LEG_{j}")].idx_q
            for j in ("HIP_P", "KNEE", "ANKLE_P")
        }
        flat = -(q[pitch["HIP_P"]] + q[pitch["KNEE"]])
        q[pitch["ANKLE_P"]] = flat
        assert robot.frame_placement(q, f"{side.lower()}_ankle").rotation[2, 2] > 1 - 1e-9
        assert flat < robot.model.lowerPositionLimit[pitch["ANKLE_P"]] - 0.2


def test_unloadable_legged_robot_raises_a_clear_error() -> None:
    with pytest.raises(ModelLoadError, match="SDF"):
        Robot.load("cassie", geometry=False)


def test_every_floating_base_robot_is_classified() -> None:
    """A robot example-robot-data adds is listed somewhere, not skipped silently."""
    floating = {name for name, loader in ROBOTS.items() if getattr(loader, "free_flyer", False)}
    tables = [set(LEGGED), set(CANNOT_STAND), set(NOT_LEGGED)]
    listed = set().union(*tables)
    assert floating <= listed, sorted(floating - listed)
    assert sum(len(t) for t in tables) == len(listed)  # no robot in two tables
