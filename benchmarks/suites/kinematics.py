"""State update + features of a 4-task stack, next to the raw Pinocchio calls (the floor).

The floor is written the way Pinocchio's examples write it (``data.oMf[i]``, ``@``); a second,
tuned floor takes the references into ``data`` once and uses ``ndarray.dot``, the two idioms
taskspace itself uses, so the table shows how much of the ratio is Pinocchio work and how much
is Python idiom. All are timed in alternating blocks of 20 calls (``measure_interleaved``) so
that the ratios do not depend on when the machine was busy.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, measure_interleaved
from taskspace import features as F
from taskspace.model import Robot

SUITE = "kinematics"


def scene(name: str) -> tuple[Robot, list[tuple[F.Feature, object]], list[np.ndarray]]:
    """Robot, four (feature, target) pairs and a sequence of configurations."""
    robot = Robot.load(name)
    rng = np.random.default_rng(0)
    qs = [robot.random_configuration(rng, base_box=0.1) for _ in range(64)]
    if name == "panda":
        feats: list[F.Feature] = [
            F.FramePose(robot, "panda_hand_tcp"),
            F.Position(robot, "panda_link4"),
            F.CenterOfMass(robot),
            F.JointConfiguration(robot),
        ]
    else:
        feats = [
            F.FramePose(robot, robot.end_effectors[0]),
            F.FramePose(robot, robot.end_effectors[1]),
            F.CenterOfMass(robot),
            F.FramePose(robot, robot.end_effectors[2]),
        ]
    s0 = robot.state(robot.q_default)
    tasks = []
    for f in feats:
        target = f.value(s0) if not isinstance(f, F.JointConfiguration) else robot.q_default
        if isinstance(f, F.FramePose | F.JointConfiguration):
            tasks.append((f, target))
        else:
            tasks.append((f, np.asarray(target)))
    return robot, tasks, qs


def taskspace_step(robot: Robot, tasks: list, qs: list) -> Callable[[], None]:  # type: ignore[type-arg]
    state = robot.state(qs[0])
    k = [0]

    def step() -> None:
        k[0] = (k[0] + 1) % len(qs)
        state.update(qs[k[0]])
        for feature, target in tasks:
            feature.residual_and_jacobian(state, target)

    return step


def raw_step(robot: Robot, tasks: list, qs: list) -> Callable[[], None]:  # type: ignore[type-arg]
    """The same quantities with direct Pinocchio calls and no validation (the floor)."""
    model = robot.model
    data = model.createData()
    LOCAL = pin.ReferenceFrame.LOCAL
    LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    plan = []
    for feature, target in tasks:
        if isinstance(feature, F.FramePose):
            plan.append(("pose", feature.frame_id, target))
        elif isinstance(feature, F.Position):
            plan.append(("pos", feature.frame_id, target))
        elif isinstance(feature, F.CenterOfMass):
            plan.append(("com", 0, target))
        else:
            plan.append(("posture", 0, target))
    k = [0]

    def step() -> None:
        k[0] = (k[0] + 1) % len(qs)
        q = qs[k[0]]
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for kind, fid, target in plan:
            if kind == "pose":
                err = target.actInv(data.oMf[fid])  # type: ignore[union-attr]
                pin.log6(err)
                pin.Jlog6(err) @ pin.getFrameJacobian(model, data, fid, LOCAL)
            elif kind == "pos":
                data.oMf[fid].translation - target
                pin.getFrameJacobian(model, data, fid, LWA)[:3]
            elif kind == "com":
                pin.jacobianCenterOfMass(model, data, True)
                data.com[0] - target
            else:
                pin.difference(model, target, q)

    return step


def raw_tuned_step(robot: Robot, tasks: list, qs: list) -> Callable[[], None]:  # type: ignore[type-arg]
    """The raw calls written for speed: references into ``data`` taken once, ``ndarray.dot``.

    Shows how much of the gap to the plain floor is Python idiom rather than Pinocchio work.
    """
    model = robot.model
    data = model.createData()
    LOCAL = pin.ReferenceFrame.LOCAL
    LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    com = data.com[0]
    plan = []
    for feature, target in tasks:
        if isinstance(feature, F.FramePose):
            plan.append(("pose", feature.frame_id, data.oMf[feature.frame_id], target))
        elif isinstance(feature, F.Position):
            plan.append(("pos", feature.frame_id, data.oMf[feature.frame_id], target))
        elif isinstance(feature, F.CenterOfMass):
            plan.append(("com", 0, None, target))
        else:
            plan.append(("posture", 0, None, target))
    k = [0]

    def step() -> None:
        k[0] = (k[0] + 1) % len(qs)
        q = qs[k[0]]
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for kind, fid, M, target in plan:
            if kind == "pose":
                err = target.actInv(M)  # type: ignore[union-attr]
                pin.log6(err)
                pin.Jlog6(err).dot(pin.getFrameJacobian(model, data, fid, LOCAL))
            elif kind == "pos":
                M.translation - target  # type: ignore[union-attr]
                pin.getFrameJacobian(model, data, fid, LWA)[:3]
            elif kind == "com":
                pin.jacobianCenterOfMass(model, data, True)
                com - target
            else:
                q - target

    return step


def run(quick: bool) -> list[Row]:
    """Both robots, taskspace vs raw Pinocchio."""
    rows = []
    rounds = 30 if quick else 300
    for name in ("panda", "talos"):
        robot, tasks, qs = scene(name)
        raw, tuned, ts = measure_interleaved(
            [
                raw_step(robot, tasks, qs),
                raw_tuned_step(robot, tasks, qs),
                taskspace_step(robot, tasks, qs),
            ],
            rounds=rounds,
        )
        scene_name = f"{name} 4-task update"
        rows.append(Row(SUITE, scene_name, "raw pinocchio", raw))
        rows.append(Row(SUITE, scene_name, "raw pinocchio, tuned", tuned, ratio_to="raw pinocchio"))
        rows.append(
            Row(
                SUITE,
                scene_name,
                "taskspace",
                ts,
                ratio_to="raw pinocchio",
                extra={"target_ratio": 1.5},
            )
        )
    return rows
