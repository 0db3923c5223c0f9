"""Load MoveIt planning scenes and motion-plan requests (MotionBenchMaker YAML files).

A MoveIt ``PlanningScene`` YAML lists ``world.collision_objects``, each with ``primitives``
(``type`` box / sphere / cylinder / cone and ``dimensions``) and ``primitive_poses``
(``position [x, y, z]`` [m] and ``orientation [x, y, z, w]``, a unit quaternion). MoveIt's
``SolidPrimitive`` conventions: box ``[size_x, size_y, size_z]``, sphere ``[radius]``,
cylinder and cone ``[height, radius]`` (axis along z, centered at the pose). Each primitive
becomes one :class:`~taskspace.model.Obstacle` named ``<id>`` (or ``<id>_<k>`` for objects with
several primitives).

A ``MotionPlanRequest`` YAML gives ``start_state.joint_state`` (names and positions) and
``goal_constraints[0].joint_constraints`` (one position per joint). Joints that the robot model
does not have as free joints (the Panda's locked fingers) are ignored and listed in
:attr:`PlanningRequest.ignored_joints`.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from taskspace._validation import YamlLines, as_float_array, as_scalar, read_yaml
from taskspace.errors import InvalidInputError, ModelLoadError
from taskspace.model.robot import Robot
from taskspace.model.world import Obstacle

logger = logging.getLogger(__name__)

MOTIONBENCHMAKER_SCENARIOS = (
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "box",
    "cage",
    "table_pick",
    "table_under_pick",
)
"""The seven Panda scenarios of MotionBenchMaker (Chamzas et al., RA-L 2022)."""


def _read_yaml(path: str | Path) -> tuple[dict[str, Any], YamlLines]:
    data, lines = read_yaml(path, "YAML file")
    if not isinstance(data, dict):
        raise ModelLoadError(f"{lines.where()}: expected a mapping at the top level")
    return data, lines


def _pose(entry: Any, where: str) -> pin.SE3:
    try:
        position = as_float_array(entry["position"], "position").reshape(3)
        quat = as_float_array(entry["orientation"], "orientation").reshape(4)  # x, y, z, w
    except (KeyError, ValueError, TypeError) as exc:
        raise ModelLoadError(
            f"{where}: pose needs position [x, y, z] and orientation [x, y, z, w]"
        ) from exc
    norm = float(np.linalg.norm(quat))
    if not np.isfinite(norm) or abs(norm - 1.0) > 1e-3:
        raise ModelLoadError(f"{where}: orientation quaternion has norm {norm}, expected 1")
    quat = quat / norm
    rotation = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
    return pin.SE3(rotation, position)


def _primitive(name: str, primitive: Any, pose: pin.SE3, where: str) -> Obstacle:
    if not isinstance(primitive, dict):
        raise ModelLoadError(f"{where}: a primitive must be a mapping, got {primitive!r}")
    kind = str(primitive.get("type", "")).lower()
    try:
        dims = as_float_array(primitive.get("dimensions", []), "dimensions").ravel().tolist()
    except InvalidInputError as exc:
        raise ModelLoadError(f"{where}: {exc}") from exc
    expected = {"box": 3, "sphere": 1, "cylinder": 2, "cone": 2}
    if kind not in expected:
        raise ModelLoadError(
            f"{where}: unsupported primitive type {kind!r}; supported: {', '.join(expected)}"
        )
    if len(dims) != expected[kind] or not all(math.isfinite(d) and d > 0 for d in dims):
        raise ModelLoadError(
            f"{where}: {kind} needs {expected[kind]} positive dimensions, got {dims}"
        )
    if kind == "box":
        return Obstacle.box(name, dims, pose)
    if kind == "sphere":
        return Obstacle.sphere(name, dims[0], pose)
    if kind == "cylinder":
        return Obstacle.cylinder(name, radius=dims[1], length=dims[0], pose=pose)
    return Obstacle(name, coal.Cone(dims[1], dims[0]), pose)


def load_moveit_scene(path: str | Path) -> list[Obstacle]:
    """Obstacles of a MoveIt planning-scene YAML file (world frame = scene frame).

    Args:
        path: ``sceneNNNN.yaml``.

    Returns:
        One obstacle per primitive, in file order.

    Raises:
        ModelLoadError: missing file, malformed YAML, unsupported shape (meshes, planes).
    """
    data, lines = _read_yaml(path)
    world = data.get("world") or {}
    if not isinstance(world, dict):
        raise ModelLoadError(f"{lines.where('world')}: 'world' must be a mapping")
    objects = world.get("collision_objects") or []
    if not isinstance(objects, list):
        raise ModelLoadError(
            f"{lines.where('world', 'collision_objects')}: collision_objects must be a list"
        )
    obstacles: list[Obstacle] = []
    for i, obj in enumerate(objects):
        at = ("world", "collision_objects", i)
        if not isinstance(obj, dict):
            raise ModelLoadError(f"{lines.where(*at)}: a collision object must be a mapping")
        oid = str(obj.get("id", f"object{len(obstacles)}"))
        for key in ("meshes", "planes"):
            if obj.get(key):
                raise ModelLoadError(
                    f"{lines.where(*at, key)}: object '{oid}' has {key}, which are not supported"
                )
        prims = obj.get("primitives") or []
        poses = obj.get("primitive_poses") or []
        if not isinstance(prims, list) or not isinstance(poses, list) or len(prims) != len(poses):
            raise ModelLoadError(
                f"{lines.where(*at)}: object '{oid}' needs lists of primitives and "
                "primitive_poses of the same length"
            )
        origin = (
            _pose(obj["pose"], f"{lines.where(*at, 'pose')}: {oid}")
            if "pose" in obj
            else pin.SE3.Identity()
        )
        for k, (prim, pose) in enumerate(zip(prims, poses)):
            name = oid if len(prims) == 1 else f"{oid}_{k}"
            pose_at = f"{lines.where(*at, 'primitive_poses', k)}: object '{name}'"
            where = f"{lines.where(*at, 'primitives', k)}: object '{name}'"
            obstacles.append(_primitive(name, prim, origin * _pose(pose, pose_at), where))
    return obstacles


@dataclass
class PlanningRequest:
    """Start and goal of a MoveIt motion-plan request, mapped onto a robot model.

    Attributes:
        start: start configuration (size nq) [rad].
        goal: goal configuration (size nq) [rad].
        ignored_joints: joints of the request that the model does not have (locked).
        group: MoveIt planning group name.
    """

    start: np.ndarray
    goal: np.ndarray
    ignored_joints: list[str] = field(default_factory=list)
    group: str = ""


def _joint_slots(robot: Robot) -> dict[str, tuple[int, int]]:
    """Joint name -> (idx_q, nq) of every joint of ``robot``.

    One read of the model's index vectors instead of a Boost call per joint and request.
    """
    model = robot._model
    idx_qs, nqs = list(model.idx_qs), list(model.nqs)
    return {name: (idx_qs[j], nqs[j]) for name, j in robot._joint_ids.items()}


def _to_configuration(
    robot: Robot,
    names: Sequence[str],
    values: Sequence[float],
    ignored: set[str],
    where: str,
    slots: dict[str, tuple[int, int]] | None = None,
) -> np.ndarray:
    q = robot.q_default.copy()
    slots = _joint_slots(robot) if slots is None else slots
    for name, value in zip(names, values):
        slot = slots.get(name) if isinstance(name, str) else None
        if slot is None:
            ignored.add(name)
            continue
        idx_q, nq = slot
        if nq != 1:
            raise InvalidInputError(f"{where}: joint '{name}' is not a 1-DoF joint")
        try:
            q[idx_q] = as_scalar(value, f"position of joint '{name}'")
        except InvalidInputError as exc:
            raise ModelLoadError(f"{where}: {exc}") from exc
    return q


@dataclass(frozen=True)
class _MoveItRequestFile:
    """What :func:`load_moveit_request` reads from a request YAML (before any robot)."""

    names: list[str]
    positions: list[Any]
    state_at: str
    """``file:line`` of the start state (for error messages)."""
    goal_names: list[str]
    goal_values: list[Any]
    goal_at: str
    """``file:line`` of the goal's joint constraints."""
    group: str


def _read_moveit_request(path: str | Path) -> _MoveItRequestFile:
    """Parse a MoveIt motion-plan request YAML (see :func:`load_moveit_request`)."""
    data, lines = _read_yaml(path)
    try:
        js = data["start_state"]["joint_state"]
        names, positions = list(js["name"]), list(js["position"])
        constraints = list(data["goal_constraints"][0]["joint_constraints"])
    except (KeyError, IndexError, TypeError) as exc:
        raise ModelLoadError(
            f"{lines.where('goal_constraints' if 'start_state' in data else 'start_state')}: "
            "expected start_state.joint_state (name, position) and "
            "goal_constraints[0].joint_constraints"
        ) from exc
    state_at = lines.where("start_state", "joint_state")
    if len(names) != len(positions):
        raise ModelLoadError(
            f"{state_at}: start_state has {len(names)} names, {len(positions)} values"
        )
    goal_names: list[str] = []
    goal_values: list[Any] = []
    for k, c in enumerate(constraints):
        if not isinstance(c, dict) or "joint_name" not in c or "position" not in c:
            raise ModelLoadError(
                f"{lines.where('goal_constraints', 0, 'joint_constraints', k)}: a joint "
                "constraint needs joint_name and position"
            )
        goal_names.append(str(c["joint_name"]))
        goal_values.append(c["position"])
    return _MoveItRequestFile(
        names=[str(n) for n in names],
        positions=positions,
        state_at=state_at,
        goal_names=goal_names,
        goal_values=goal_values,
        goal_at=lines.where("goal_constraints", 0, "joint_constraints"),
        group=str(data.get("group_name", "")),
    )


def _request_on(robot: Robot, request: _MoveItRequestFile) -> PlanningRequest:
    """The start and goal of a parsed request on ``robot``'s model."""
    ignored: set[str] = set()
    slots = _joint_slots(robot)
    start = _to_configuration(
        robot, request.names, request.positions, ignored, request.state_at, slots
    )
    goal = start.copy()
    goal_from = _to_configuration(
        robot, request.goal_names, request.goal_values, ignored, request.goal_at, slots
    )
    for name in request.goal_names:
        slot = slots.get(name) if isinstance(name, str) else None
        if slot is not None:
            goal[slot[0]] = goal_from[slot[0]]
    return PlanningRequest(
        start=start, goal=goal, ignored_joints=sorted(ignored), group=request.group
    )


def load_moveit_request(robot: Robot, path: str | Path) -> PlanningRequest:
    """Start and goal configurations of a MoveIt motion-plan request YAML.

    Args:
        robot: the robot model (joint names must match the request's).
        path: ``requestNNNN.yaml``.

    Raises:
        ModelLoadError: missing file or fields, no joint constraint.
    """
    return _request_on(robot, _read_moveit_request(path))


@dataclass
class MotionBenchMakerProblem:
    """One MotionBenchMaker problem: file paths and parsed content.

    Attributes:
        scenario: scenario name (``bookshelf_small``...).
        index: problem number (1-based, as in the file names).
        scene_path: scene YAML.
        request_path: request YAML.
        obstacles: obstacles of the scene.
    """

    scenario: str
    index: int
    scene_path: Path
    request_path: Path
    obstacles: list[Obstacle]
    _request: _MoveItRequestFile | None = field(default=None, repr=False, compare=False)
    """The request file as read by :func:`motionbenchmaker_problems` (None: read at
    :meth:`request`), so that applying a problem reads no file."""

    def request(self, robot: Robot) -> PlanningRequest:
        """Start and goal on ``robot``'s model."""
        if self._request is None:
            return load_moveit_request(robot, self.request_path)
        return _request_on(robot, self._request)

    def apply(self, robot: Robot) -> PlanningRequest:
        """Replace ``robot``'s obstacles by this scene's and return the request."""
        robot.clear_obstacles()
        robot.add_obstacles(self.obstacles)
        return self.request(robot)


def motionbenchmaker_panda(*, finger_opening: float = 0.04, convex_collision: bool = True) -> Robot:
    """The registry's Panda (example-robot-data) with the fingers locked open, as in the requests.

    The MotionBenchMaker requests hold both fingers at 0.065 m, beyond the URDF's 0.04 m
    limit; the registry Panda locks them closed (0.001 m), which puts them inside the object
    to grasp at most goals. This model locks them at ``finger_opening`` (default: the limit).

    Args:
        finger_opening: position of each finger joint [m].
        convex_collision: check convex hulls of the link meshes (default; about 20 % faster
            than the meshes with the broadphase) instead of the meshes.
    """
    robot = Robot.load(
        "panda",
        convex_collision=convex_collision,
        locked_values={
            "panda_finger_joint1": finger_opening,
            "panda_finger_joint2": finger_opening,
        },
    )
    robot.description = f"{robot.description}, fingers locked at {finger_opening} m"
    return robot


MOTIONBENCHMAKER_ENV = "TASKSPACE_MOTIONBENCHMAKER_DIR"
"""Environment variable naming the MotionBenchMaker Panda directory."""


def motionbenchmaker_dir(root: str | Path | None = None) -> Path:
    """Directory of the MotionBenchMaker Panda problems (``<scenario>_panda/*.yaml``).

    taskspace does not ship these files: the directory is ``root`` when given, else the
    environment variable ``TASKSPACE_MOTIONBENCHMAKER_DIR``; no other place is searched.

    Args:
        root: the directory (``None``: the environment variable).

    Raises:
        ModelLoadError: neither is given, or the directory does not exist.
    """
    if root is None:
        env = os.environ.get(MOTIONBENCHMAKER_ENV, "")
        if not env:
            raise ModelLoadError(
                "MotionBenchMaker Panda problems: pass their directory or set "
                f"{MOTIONBENCHMAKER_ENV} (the directory holding bookshelf_small_panda/, "
                "cage_panda/, ...)"
            )
        root = env
    path = Path(root)
    if not path.is_dir():
        raise ModelLoadError(
            f"MotionBenchMaker Panda directory {path} does not exist (pass their directory "
            f"or set {MOTIONBENCHMAKER_ENV})"
        )
    return path


def motionbenchmaker_problems(
    root: str | Path, scenario: str, indices: Sequence[int] | None = None
) -> list[MotionBenchMakerProblem]:
    """Problems of one MotionBenchMaker scenario found under ``root``.

    Args:
        root: directory holding ``<scenario>_panda/sceneNNNN.yaml`` and ``requestNNNN.yaml``
            (or ``<scenario>/...``).
        scenario: one of :data:`MOTIONBENCHMAKER_SCENARIOS` (or any directory name).
        indices: problem numbers to load (default: every scene file found).

    Raises:
        ModelLoadError: the scenario directory does not exist, or a file is missing or
            malformed (the scenes and requests are read here).
    """
    base = Path(root)
    folder = next((d for d in (base / f"{scenario}_panda", base / scenario) if d.is_dir()), None)
    if folder is None:
        found = sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []
        raise ModelLoadError(
            f"no scenario '{scenario}' under {base}; found: {', '.join(found) or 'nothing'}"
        )
    if indices is None:
        indices = sorted(int(p.stem[5:]) for p in folder.glob("scene*.yaml"))
    problems = []
    for i in indices:
        scene = folder / f"scene{i:04d}.yaml"
        request = folder / f"request{i:04d}.yaml"
        if not request.is_file():
            raise ModelLoadError(f"request file not found: {request}")
        problems.append(
            MotionBenchMakerProblem(
                scenario=scenario,
                index=int(i),
                scene_path=scene,
                request_path=request,
                obstacles=load_moveit_scene(scene),
                _request=_read_moveit_request(request),
            )
        )
    return problems
