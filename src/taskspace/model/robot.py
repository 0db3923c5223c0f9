"""``Robot``: a Pinocchio model, its coal collision geometry and an obstacle world.

Every joint type of Pinocchio is handled (:meth:`Robot.check_configuration`,
:meth:`Robot.random_configuration`, :meth:`Robot.neutral`, :meth:`Robot.interpolate`,
:meth:`Robot.distance`, limits): revolute and prismatic joints on any axis (bounded or not),
continuous joints (``JointModelRUBX/Y/Z``, ``RevoluteUnboundedUnaligned``: ``(cos, sin)``,
nq = 2, nv = 1), spherical (unit quaternion), planar (``x, y, cos, sin``) and free-flyer
(``x, y, z`` and a unit quaternion) joints, and the other joints with nq = nv (spherical ZYX,
translation, universal, helical). Composite joints raise :class:`ModelLoadError`.

Models are checked on load (:func:`prune_collision_pairs`, :class:`CollisionPruningOptions`):

* collision pairs of geometries on the same or adjacent joints are disabled when no SRDF is
  given (with an SRDF its ``disable_collisions`` list is applied instead);
* pairs in collision at the default posture are disabled (MoveIt setup assistant's "default");
* pairs in collision in at least ``fraction`` (95 %) of ``samples`` (100) random
  configurations within the joint limits are disabled (MoveIt's "always"), also when an SRDF
  is given;

each disabled pair of the last two rules is reported with a :class:`ModelWarning` and listed in
:attr:`Robot.pruned_collision_pairs`. The pairs left are then tried on 20 random configurations:
when at least ``fraction`` of them are still in self-collision (no single pair is, but the robot
is: icub, romeo, centauro), a :class:`ModelWarning` names the pairs most often in contact, since
sampling planners would find almost no free space
(:attr:`PrunedCollisionPairs.self_collision_rate`).

Missing limits: an effort limit of 0 in the description (URDF ``effort="0"``, or none) is read
as *unknown* and the joint is treated as actuated without limit (``inf``), with a
:class:`ModelWarning`; a joint that is really passive (unactuated) must be declared in
``passive_joints`` (registry key ``passive_joints``). A velocity limit of 0 is read as unknown
and treated as unlimited (``inf``), with a warning. The floating base is never actuated.

Joints that move no mass: a joint whose diagonal entry of the mass matrix is zero at the
default posture (every body it carries is massless, e.g. romeo's fingers) makes the mass
matrix singular and forward dynamics undefined (NaN accelerations). Such joints get a rotor
inertia (``model.armature``) of 1 % of the smallest nonzero diagonal entry of the mass matrix,
listed in :attr:`Robot.massless_joints`, with a :class:`ModelWarning`.

Model version: the limits a robot exposes (:attr:`Robot.lower_limits`, :attr:`Robot.upper_limits`,
:attr:`Robot.velocity_limits`, :attr:`Robot.effort_limits`, the limited-joint indices) are
read-only arrays, changed only by :meth:`Robot.set_limits` (or :meth:`Robot.edit_model`),
which gives the robot a new :attr:`Robot.version` (drawn from one process-wide counter: a
version is never reused). Objects built from the robot that keep limits (constraints, features,
solvers, planning spaces) record the version and rebuild or raise :class:`StaleModelError`
(:meth:`Robot.check_version`) when it differs. The robot owns its Pinocchio objects:
``robot.model``, ``robot.collision_model`` and ``robot.visual_model`` are copies, so an edit
made on them cannot bypass the versions; the model's values change through
:meth:`Robot.edit_model`, the collision geometry through :meth:`Robot.edit_collision_model`.

Thread safety: :class:`Robot` may be shared by threads that read it (see there: its own Pinocchio
data is used under a lock); :class:`CollisionPruningOptions` and :class:`PrunedCollisionPairs` are
immutable values; :func:`prune_collision_pairs` modifies the robot it is given (run on load: not
while other threads use that robot).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
import os
import threading
import warnings
import weakref
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    as_vector,
    check_finite,
    check_positive,
)
from taskspace.errors import (
    InvalidInputError,
    LimitError,
    ModelLoadError,
    ModelWarning,
    ShapeError,
    StaleModelError,
    UnknownNameError,
)
from taskspace.model.collision_requests import without_cached_guess
from taskspace.model.registry import RobotSpec, example_robot_data_loaders, robot_spec
from taskspace.model.urdf_check import (
    srdf_problem,
    urdf_mimic_joints,
    urdf_physical_problem,
    urdf_problem,
)
from taskspace.model.world import Obstacle, World

if TYPE_CHECKING:
    from taskspace.model.state import State

logger = logging.getLogger(__name__)

_F64 = np.dtype(np.float64)
IntArray = npt.NDArray[np.int64]

QUATERNION_TOLERANCE = 1e-6
"""Largest accepted deviation of a quaternion's (or unit complex's) norm from 1."""

_ROBOT_VERSIONS = itertools.count(1)
"""Source of robot model versions, shared by every robot (a version is never reused)."""

_DATA_LOCK = threading.Lock()
"""Guards the robots' own ``data``/``collision_data`` (evaluate, then read the results).

One lock for all robots (a lock attribute would make robots impossible to deep-copy); it is
held only by :meth:`Robot.frame_placement`, :meth:`Robot.is_collision_free` and
:meth:`Robot.colliding_pairs`, never while calling other code.
"""

_MESHES = coal.CachedMeshLoader()
"""The mesh files read by every load of this process, once per (file, scale): coal reloads a
file whose modification time changed. One loader for the process: a loader created per load
and passed to ``buildGeomFromUrdf`` is never freed, nor are its meshes (pin 4.1, coal 3.0.3),
so every load kept all of its meshes. The robots of one process share these read-only
meshes; nothing in taskspace modifies a loaded shape in place (the robot hands out clones;
convex hulls are built on clones)."""
_MESHES_LOCK = threading.Lock()
"""Held while a URDF's geometry is read (the loader's cache is not thread-safe)."""

_UNIT_COMPLEX_JOINTS = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
_LINEAR_JOINTS = (
    "JointModelPX",
    "JointModelPY",
    "JointModelPZ",
    "JointModelPrismaticUnaligned",
    "JointModelTranslation",
)


@dataclass(frozen=True, kw_only=True)
class CollisionPruningOptions:
    """How collision pairs are checked and pruned on load (see the module docstring).

    Attributes:
        enabled: prune at all (False keeps every pair the SRDF or the adjacency rule leaves).
        adjacent: without an SRDF, disable pairs on the same or adjacent joints.
        default_posture: disable pairs in collision at the default posture.
        samples: number ``N`` of random configurations of the "always in collision" test.
        fraction: a pair in collision in at least ``fraction * N`` of them is disabled.
        seed: seed of the random configurations (the result is reproducible).
    """

    enabled: bool = True
    adjacent: bool = True
    default_posture: bool = True
    samples: int = 100
    fraction: float = 0.95
    seed: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.samples, bool) or not isinstance(self.samples, int):
            raise InvalidInputError(f"samples must be an int, got {self.samples!r}")
        if self.samples < 0:
            raise InvalidInputError(f"samples must be >= 0, got {self.samples}")
        if not (isinstance(self.fraction, (int, float)) and 0.0 < self.fraction <= 1.0):
            raise InvalidInputError(f"fraction must be in (0, 1], got {self.fraction!r}")


@dataclass(frozen=True)
class PrunedCollisionPairs:
    """Collision pairs disabled on load, by rule, as (geometry name, geometry name).

    Attributes:
        adjacent: same or adjacent joints (only without an SRDF).
        default_posture: in collision at the default posture.
        always: in collision in at least ``fraction`` of ``samples`` random configurations.
        samples: number of random configurations of the last rule.
        fraction: its threshold.
        self_collision_rate: after pruning, the fraction of ``rate_samples`` random
            configurations within the joint limits that are still in self-collision (NaN
            when not estimated). Near 1 the sampling planners find almost no free space;
            a :class:`ModelWarning` says so on load.
        rate_samples: number of random configurations of that estimate.
    """

    adjacent: tuple[tuple[str, str], ...] = ()
    default_posture: tuple[tuple[str, str], ...] = ()
    always: tuple[tuple[str, str], ...] = ()
    samples: int = 0
    fraction: float = 1.0
    self_collision_rate: float = math.nan
    rate_samples: int = 0


class Robot:
    """A robot: kinematic/dynamic model, collision and visual geometry, obstacle world.

    Create with :meth:`load` (any name of :func:`~taskspace.model.registry.available_robots`:
    our registry and every robot of example-robot-data) or :meth:`from_urdf`. The robot owns
    its Pinocchio objects (the constructor copies the ones it is given) and hands out
    read-only copies (:attr:`model`, :attr:`collision_model`, :attr:`visual_model`; a new
    copy after each change of the robot): editing what they return changes nothing of the
    robot and of the objects built from it. Changes go through the robot, which then gets a
    new :attr:`version` (and its world a new :attr:`~taskspace.model.World.version`) that
    every derived object follows:
    :meth:`set_limits`, :meth:`edit_model` (inertias, joint and frame placements, rotor
    parameters, gravity, limits), :meth:`edit_collision_model` (geometry placements and
    shapes, collision pairs), the obstacle and collision-pair methods.

    Attributes:
        name: robot name.
        end_effectors: names of the end-effector frames.
        passive_joints: names of the unactuated joints (effort limit 0).
        pruned_collision_pairs: collision pairs disabled on load and why.
        massless_joints: joints that move no mass and were given an armature (see the
            module docstring).

    Thread safety: a robot may be shared by threads that read it. Its queries (limits,
    configuration checks, ``random_configuration`` with each thread's own generator,
    interpolation, distances) are functions of their arguments; :meth:`frame_placement`,
    :meth:`is_collision_free` and :meth:`colliding_pairs` evaluate into the robot's own
    ``data``/``collision_data`` under a lock (one for all robots: threads take turns), so many
    evaluations belong in a :class:`~taskspace.model.State` or a collision checker per thread.
    The mutators (:meth:`set_limits`, :meth:`edit_model`, :meth:`edit_collision_model`,
    obstacles, collision pairs) are not locked: do not call them while other threads use the
    robot or objects built from it.
    """

    def __init__(
        self,
        model: pin.Model,
        collision_model: pin.GeometryModel,
        visual_model: pin.GeometryModel,
        *,
        name: str,
        end_effectors: Sequence[str] = (),
        default_configuration: FloatArray | None = None,
        srdf_path: str | None = None,
        description: str = "",
        passive_joints: Sequence[str] = (),
    ) -> None:
        self.name = name
        self.description = description
        # the robot's own copies: what a caller keeps of its arguments cannot edit the robot
        self._model = model.copy()
        self._visual_model = visual_model.copy()
        self._collision_model = collision_model.copy()
        _clone_shapes(self._collision_model)  # pin's copy shares the coal shapes
        model, collision_model = self._model, self._collision_model
        self._model_copy: pin.Model | None = None  # what the public accessors hand out
        self._model_copy_version = 0
        self._collision_copy: pin.GeometryModel | None = None
        self._collision_copy_stamp = (0, 0)
        # clones of the costly shapes (meshes...) kept for the next copies, by geometry name
        self._shape_clones: dict[str, Any] = {}
        self._model_armature = np.asarray(model.armature, dtype=float).copy()  # before the rule
        self._visual_copy: pin.GeometryModel | None = None
        self._geometry_edits = 0  # edit_collision_model calls (caches of shapes follow it)
        self.srdf_path = srdf_path
        self._world = World()
        self._world._owner = self  # its add/remove/clear go through this robot
        self.pruned_collision_pairs = PrunedCollisionPairs()
        self._robot_geometry_count = collision_model.ngeoms
        self._frame_ids = {f.name: i for i, f in enumerate(model.frames)}
        self._joint_ids = {n: i for i, n in enumerate(model.names) if i > 0}
        for ee in end_effectors:
            self.frame_id(ee)
        self.end_effectors = tuple(end_effectors)
        self._nq = int(model.nq)
        self._nv = int(model.nv)
        self._q_shape = (self._nq,)
        self._v_shape = (self._nv,)
        # the fast finiteness test: x.dot(tiny) is finite exactly when x is (2^-1000 |x_i| <
        # 2^24, so the sum cannot overflow; x.dot(x) did for |x| > 1e154, with a RuntimeWarning)
        self._q_tiny = np.full(self._nq, 2.0**-1000)
        self._v_tiny = np.full(self._nv, 2.0**-1000)
        self._data = model.createData()
        # the robot's own collision data, made at its first use (None: not made since the
        # collision model last changed; a GeometryData costs about 2 us per collision pair)
        self._collision_data: Any = None
        self._guess_reset: Any = None  # the collision data whose cached GJK guess is off
        self._version = next(_ROBOT_VERSIONS)
        # every live State of this robot (edit_model re-evaluates them at the new values)
        self._states: weakref.WeakSet[Any] = weakref.WeakSet()
        self._setup_joint_structure()
        self._warn_equal_limits()
        self._setup_actuation_limits(passive_joints)
        if default_configuration is None:
            default_configuration = pin.neutral(model)
        q_default = self.check_configuration(default_configuration, "default_configuration")
        self._q_default = self._posture_into_limits(q_default)
        self._q_default.flags.writeable = False
        self._setup_massless_joints()

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(
        cls,
        name: str,
        *,
        convex_collision: bool = False,
        locked_values: dict[str, float] | None = None,
        collision_pruning: CollisionPruningOptions | None = None,
        geometry: bool = True,
        base: str | None = None,
    ) -> Robot:
        """Load a robot by name: our registry, or any robot of example-robot-data.

        Our registry (``taskspace/robots_data/registry.yaml``) adds end effectors, locked
        joints and a default posture to some robots; any other robot that example-robot-data
        provides loads with its loader's free flyer, SRDF (collision pairs, reference
        posture) and reference posture. See :func:`~taskspace.model.registry.available_robots`
        or ``taskspace robots`` for the names.

        Args:
            name: robot name (``panda``, ``ur5``, ``talos``, ``g1``, ``solo12``, ``go2``,
                ``kinova``, ``tiago``, ``planar_2link``, ``pendulum``, ``cartpole``...).
            convex_collision: replace collision meshes by their convex hulls (distance
                queries become ~30x cheaper; needed for distance-based features).
            locked_values: values [rad or m] at which the registry's locked joints are held
                (e.g. ``{"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}``);
                default their default-posture values.
            collision_pruning: how collision pairs are checked on load (default
                :class:`CollisionPruningOptions`).
            geometry: read the collision and visual geometry (meshes). ``False`` gives a
                kinematics and dynamics model only, with empty geometry models (like a URDF
                without ``<collision>`` and ``<visual>`` elements): it loads several times
                faster, and its self-collision checks see no robot geometry.
            base: the root joint that attaches the robot to the world: ``None`` (the
                registry's: a free flyer for legged robots, fixed otherwise), ``"fixed"``,
                ``"planar"`` (Pinocchio's ``JointModelPlanar``: x, y [m] and yaw on the
                ground, configuration ``(x, y, cos, sin)``; e.g. ``Robot.load("tiago",
                base="planar")`` for a mobile manipulator whose base is planned with its
                arm) or ``"free_flyer"``. Robots built by their own example-robot-data
                loader (not a plain URDF) take only ``None``.

        Raises:
            UnknownNameError: ``name`` is not a known robot (the message lists the names).
            ModelLoadError: the description files cannot be read (missing meshes...).
        """
        if not isinstance(geometry, bool):
            raise InvalidInputError(f"geometry must be True or False, got {geometry!r}")
        spec = robot_spec(name)
        root = _check_base(base)
        free_flyer = spec.free_flyer if root is None else root == "free_flyer"
        common: dict[str, Any] = {
            "locked_joints": spec.locked_joints,
            "name": name,
            "end_effectors": spec.end_effectors,
            "convex_collision": convex_collision,
            "locked_values": locked_values,
            "passive_joints": spec.passive_joints,
            "collision_pruning": collision_pruning,
            "_posture": spec,
            "geometry": geometry,
        }
        if spec.source == "example-robot-data":
            loaders = example_robot_data_loaders()
            if spec.erd_name not in loaders:
                raise ModelLoadError(
                    f"registry entry '{name}' names example-robot-data robot "
                    f"'{spec.erd_name}', which this example-robot-data does not provide; "
                    f"its robots are: {', '.join(sorted(loaders))}"
                )
            loader = loaders[spec.erd_name]
            if _is_plain_loader(loader):
                urdf, package_dirs, srdf = _erd_paths(loader)
                robot = cls.from_urdf(
                    urdf,
                    free_flyer=free_flyer,
                    base=root,
                    package_dirs=package_dirs,
                    srdf=srdf,
                    **common,
                )
            else:
                if root is not None:
                    raise InvalidInputError(
                        f"base={base!r}: robot '{name}' is built by its own example-robot-data "
                        "loader (not a plain URDF), which fixes its root joint; load it with "
                        "base=None"
                    )
                robot = cls._from_erd_loader(loader, **common)
        else:
            if spec.urdf is None:
                raise ModelLoadError(f"registry entry '{name}' has no urdf path")
            dirs = [str(spec.urdf.parent)]
            robot = cls.from_urdf(
                spec.urdf, free_flyer=free_flyer, base=root, package_dirs=dirs, **common
            )
        robot.description = spec.description
        return robot

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        *,
        free_flyer: bool = False,
        package_dirs: Sequence[str] | None = None,
        srdf: str | Path | None = None,
        locked_joints: Sequence[str] = (),
        name: str | None = None,
        end_effectors: Sequence[str] = (),
        default_configuration: Any = None,
        convex_collision: bool = False,
        locked_values: dict[str, float] | None = None,
        passive_joints: Sequence[str] = (),
        collision_pruning: CollisionPruningOptions | None = None,
        geometry: bool = True,
        _posture: RobotSpec | None = None,
        base: str | None = None,
    ) -> Robot:
        """Load any URDF.

        Args:
            path: URDF file.
            free_flyer: add a floating base (free-flyer root joint).
            package_dirs: directories searched for ``package://`` mesh paths.
            srdf: SRDF file: disabled collision pairs and reference configurations.
            locked_joints: joints removed from the model, held at their default value.
            name: robot name (default: the URDF file stem).
            end_effectors: names of end-effector frames.
            default_configuration: default posture (size of the unreduced model's nq).
            convex_collision: replace collision meshes by their convex hulls.
            locked_values: values [rad or m] of locked joints (default: their default value).
            passive_joints: unactuated joints (their effort limit is 0); any other joint
                whose effort limit is 0 or missing is treated as unlimited, with a warning.
            collision_pruning: how collision pairs are checked on load.
            geometry: read the collision and visual geometry (``False``: empty geometry
                models, see :meth:`load`).
            base: root joint ``"fixed"``, ``"planar"`` or ``"free_flyer"`` (see
                :meth:`load`); ``None``: a free flyer when ``free_flyer``, else fixed.

        Raises:
            InvalidInputError: an unknown ``base``, or ``free_flyer=True`` with another base.
            ModelLoadError: missing or malformed URDF/SRDF, unknown locked joint, missing
                meshes, unsupported joint type.
        """
        if not isinstance(geometry, bool):
            raise InvalidInputError(f"geometry must be True or False, got {geometry!r}")
        if not isinstance(path, (str, os.PathLike)):
            raise InvalidInputError(
                f"path must be a URDF file path (str or Path), got {type(path).__name__}"
            )
        path = Path(path)
        if not path.is_file():
            raise ModelLoadError(f"URDF file not found: {path}")
        dirs = list(package_dirs) if package_dirs is not None else [str(path.parent)]
        kind = _check_base(base)
        if kind is not None and free_flyer and kind != "free_flyer":
            raise InvalidInputError(f"free_flyer=True contradicts base={base!r}")
        if kind is None:
            kind = "free_flyer" if free_flyer else "fixed"
        root = {
            "fixed": None,
            "planar": pin.JointModelPlanar,
            "free_flyer": pin.JointModelFreeFlyer,
        }
        root_joint = root[kind]() if root[kind] is not None else None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if root_joint is None:
                    model = pin.buildModelFromUrdf(str(path))
                else:
                    model = pin.buildModelFromUrdf(str(path), root_joint)
                if geometry:
                    # one mesh file is read once per process for both models and every link
                    # that shows it (a quadruped's four legs), see _MESHES
                    with _MESHES_LOCK:
                        collision = pin.buildGeomFromUrdf(
                            model, str(path), pin.COLLISION, package_dirs=dirs, mesh_loader=_MESHES
                        )
                        visual = pin.buildGeomFromUrdf(
                            model, str(path), pin.VISUAL, package_dirs=dirs, mesh_loader=_MESHES
                        )
                else:
                    collision, visual = pin.GeometryModel(), pin.GeometryModel()
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with C++ text
            if "could not be found" in str(exc):  # what pin says when a mesh file is not found
                raise ModelLoadError(
                    f"cannot load the geometry of URDF {path}: a mesh file could not be found "
                    f"(package:// paths are searched in {dirs}; pass package_dirs=[the "
                    "directory that contains the package folder], or geometry=False)"
                ) from exc
            problem = urdf_problem(path)
            raise ModelLoadError(
                f"cannot load URDF {problem}"
                if problem
                else f"cannot load URDF {path}: {exc} (Pinocchio's parser printed the cause above)"
            ) from exc
        problem = urdf_physical_problem(path)
        if problem:
            raise ModelLoadError(f"cannot load URDF {problem}")
        mimic = {
            j: rule
            for j, rule in urdf_mimic_joints(path).items()
            if j not in locked_joints and model.existJointName(j)
        }
        if mimic:
            warnings.warn(
                ModelWarning(
                    f"robot '{name or path.stem}': joints "
                    f"{', '.join(f'{j} ({rule})' for j, rule in mimic.items())} mimic another "
                    "joint in the URDF; taskspace models them as independent joints "
                    "(Pinocchio's default), so nothing holds them at their mimic value: set "
                    "them in every configuration, or lock them (locked_joints=[...])"
                ),
                stacklevel=2 if _posture is None else 3,
            )
        if srdf is not None:
            if not Path(srdf).is_file():
                raise ModelLoadError(f"SRDF file not found: {srdf}")
            problem = srdf_problem(srdf)
            if problem:
                raise ModelLoadError(f"cannot read SRDF {problem}")
            try:
                _load_reference_configurations(model, Path(srdf))
            except ModelLoadError:
                raise
            except Exception as exc:
                raise ModelLoadError(f"cannot read SRDF {srdf}: {exc}") from exc
        q_full = pin.neutral(model)
        if _posture is None and default_configuration is not None:
            q_full = as_vector(default_configuration, model.nq, "default_configuration")
        return cls._assemble(
            model,
            collision,
            visual,
            q_full=q_full,
            srdf=str(srdf) if srdf is not None else None,
            name=name or path.stem,
            locked_joints=locked_joints,
            end_effectors=end_effectors,
            convex_collision=convex_collision,
            locked_values=locked_values,
            passive_joints=passive_joints,
            collision_pruning=collision_pruning,
            posture=_posture,
        )

    @classmethod
    def _from_erd_loader(
        cls,
        loader: Any,
        *,
        locked_joints: Sequence[str],
        name: str,
        end_effectors: Sequence[str],
        convex_collision: bool,
        locked_values: dict[str, float] | None,
        passive_joints: Sequence[str],
        collision_pruning: CollisionPruningOptions | None,
        geometry: bool,
        _posture: RobotSpec | None,
    ) -> Robot:
        """A robot built by an example-robot-data loader of its own (SDF, reduced models...)."""
        if getattr(loader, "sdf_filename", "") and not hasattr(pin, "buildModelFromSdf"):
            raise ModelLoadError(
                f"example-robot-data describes '{name}' with an SDF file "
                f"({loader.sdf_filename}), and this Pinocchio {pin.__version__} is built without "
                "SDF support (pin.buildModelFromSdf is missing); install a Pinocchio built with "
                "SDFormat or load another robot"
            )
        try:
            with (
                warnings.catch_warnings(),
                open(os.devnull, "w") as devnull,
                contextlib.redirect_stdout(devnull),
            ):
                warnings.simplefilter("ignore")
                inst = loader()
        except Exception as exc:  # any failure of the third-party loader
            raise ModelLoadError(
                f"example-robot-data cannot load '{name}': {type(exc).__name__}: {exc}"
            ) from exc
        wrapper = inst.robot
        q0 = np.asarray(wrapper.q0, dtype=float).copy()
        srdf = getattr(inst, "srdf_path", None)
        return cls._assemble(
            wrapper.model,
            wrapper.collision_model if geometry else pin.GeometryModel(),
            wrapper.visual_model if geometry else pin.GeometryModel(),
            q_full=q0,
            srdf=srdf,
            name=name,
            locked_joints=locked_joints,
            end_effectors=end_effectors,
            convex_collision=convex_collision,
            locked_values=locked_values,
            passive_joints=passive_joints,
            collision_pruning=collision_pruning,
            posture=_posture if _posture is not None and _posture.in_registry else None,
        )

    @classmethod
    def _assemble(
        cls,
        model: pin.Model,
        collision: pin.GeometryModel,
        visual: pin.GeometryModel,
        *,
        q_full: FloatArray,
        srdf: str | None,
        name: str,
        locked_joints: Sequence[str],
        end_effectors: Sequence[str],
        convex_collision: bool,
        locked_values: dict[str, float] | None,
        passive_joints: Sequence[str],
        collision_pruning: CollisionPruningOptions | None,
        posture: RobotSpec | None,
    ) -> Robot:
        """Posture, locked joints, unlimited floating base, collision pairs, then the Robot."""
        if posture is not None:
            q_full = _posture_from_spec(model, posture, q_full)
        for jname, value in (locked_values or {}).items():
            if jname not in locked_joints:
                raise UnknownNameError("locked joint", jname, locked_joints)
            jid = model.getJointId(jname)
            # a NaN value placed the locked joint's links (and their geometry) at NaN
            q_full[model.joints[jid].idx_q] = as_scalar(value, f"locked_values['{jname}']")
        if locked_joints:
            names = {n: i for i, n in enumerate(model.names) if i > 0}
            ids = []
            for j in locked_joints:
                if j not in names:
                    raise UnknownNameError("joint", j, names)
                ids.append(names[j])
            model_r, (collision, visual) = pin.buildReducedModel(
                model, [collision, visual], ids, q_full
            )
            keep = [
                model.joints[i].idx_q + k
                for i in range(1, model.njoints)
                if i not in ids
                for k in range(model.joints[i].nq)
            ]
            q_full = q_full[keep]
            model = model_r
        q_full = np.asarray(pin.normalize(model, q_full))

        # Unlimited floating bases (Pinocchio stores +-max float, example-robot-data +-1).
        lower = model.lowerPositionLimit.copy()
        upper = model.upperPositionLimit.copy()
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            if joint.shortname() == "JointModelFreeFlyer":
                lower[joint.idx_q : joint.idx_q + 7] = -np.inf
                upper[joint.idx_q : joint.idx_q + 7] = np.inf
        model.lowerPositionLimit = lower
        model.upperPositionLimit = upper

        _drop_orphan_geometries(model, collision, name, "collision")
        _drop_orphan_geometries(model, visual, name, "visual")
        if convex_collision:
            _convexify(collision)
        collision.removeAllCollisionPairs()
        collision.addAllCollisionPairs()
        options = collision_pruning or CollisionPruningOptions()
        adjacent: list[tuple[str, str]] = []
        if srdf is not None:
            try:
                pin.removeCollisionPairs(model, collision, str(srdf), False)
            except Exception as exc:
                raise ModelLoadError(f"cannot read collision pairs of SRDF {srdf}: {exc}") from exc
        elif options.enabled and options.adjacent:
            adjacent = _remove_adjacent_pairs(model, collision)
        robot = cls(
            model,
            collision,
            visual,
            name=name,
            end_effectors=end_effectors,
            default_configuration=q_full,
            srdf_path=srdf,
            passive_joints=passive_joints,
        )
        if options.enabled:
            prune_collision_pairs(robot, options, adjacent=adjacent)
        return robot

    # ------------------------------------------------------------------ structure
    def _setup_joint_structure(self) -> None:
        """Classify the joints: normalized blocks, scalar coordinates, unbounded ones."""
        model = self._model
        self._normalized_blocks: list[tuple[int, int, str]] = []  # (idx_q, size, joint name)
        scalar_q: list[int] = []
        scalar_v: list[int] = []
        linear_q: list[int] = []  # unbounded translations: sampled in a box
        self._free_translations: list[int] = []  # idx_q of free-flyer / planar positions
        continuous_q: list[int] = []  # the (cos, sin) pair of each continuous joint
        continuous_v: list[int] = []
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            short = joint.shortname()
            jname = str(model.names[jid])
            if short == "JointModelFreeFlyer":
                self._free_translations += [joint.idx_q, joint.idx_q + 1, joint.idx_q + 2]
                self._normalized_blocks.append((joint.idx_q + 3, 4, jname))
            elif short == "JointModelSpherical":
                self._normalized_blocks.append((joint.idx_q, 4, jname))
            elif short == "JointModelPlanar":
                self._free_translations += [joint.idx_q, joint.idx_q + 1]
                self._normalized_blocks.append((joint.idx_q + 2, 2, jname))
            elif short in _UNIT_COMPLEX_JOINTS or short == "JointModelRevoluteUnboundedUnaligned":
                self._normalized_blocks.append((joint.idx_q, 2, jname))
                continuous_q.append(joint.idx_q)
                continuous_v.append(joint.idx_v)
            elif joint.nq == joint.nv:
                for k in range(joint.nq):
                    scalar_q.append(joint.idx_q + k)
                    scalar_v.append(joint.idx_v + k)
                    if short in _LINEAR_JOINTS:
                        linear_q.append(joint.idx_q + k)
            else:
                raise ModelLoadError(
                    f"joint '{jname}' has type {short} (nq={joint.nq}, nv={joint.nv}), which "
                    "taskspace does not support; supported: revolute, prismatic, continuous "
                    "(RUB), spherical, planar, free-flyer and the other joints with nq = nv"
                )
        self._linear_q = frozenset(linear_q)
        # continuous_joint_indices(model), for interpolate/difference without a joint loop
        self._continuous = (
            np.array(continuous_q, dtype=np.int64),
            np.array(continuous_v, dtype=np.int64),
        )
        self.is_floating = (
            model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer"
        )
        # velocity coordinates of a mobile base: the root joint's when it is a free-flyer (6)
        # or planar (3: x, y, yaw), else 0 (joint friction and the like skip them)
        root = model.joints[1] if model.njoints > 1 else None
        self.base_nv = (
            int(root.nv)
            if root is not None and root.shortname() in ("JointModelFreeFlyer", "JointModelPlanar")
            else 0
        )
        sq = np.asarray(scalar_q, dtype=int)
        lower = np.asarray(model.lowerPositionLimit)[sq] if sq.size else np.empty(0)
        upper = np.asarray(model.upperPositionLimit)[sq] if sq.size else np.empty(0)
        finite = np.isfinite(lower) & np.isfinite(upper) & (upper > lower) & (upper - lower < 1e10)
        self._limited_q = sq[finite]
        self._limited_v = np.asarray(scalar_v, dtype=int)[finite]
        self._limited_q.flags.writeable = False
        self._limited_v.flags.writeable = False
        self._lower = np.array(model.lowerPositionLimit, dtype=np.float64)
        self._upper = np.array(model.upperPositionLimit, dtype=np.float64)
        self._lower.flags.writeable = False
        self._upper.flags.writeable = False
        unbounded = sq[~finite]
        # the limits users read: -inf/+inf on the scalar coordinates treated as unlimited
        # (equal limits such as a URDF's missing (0, 0), spans of 1e10 or more), so that no
        # reader clips or bounds them by values the robot does not enforce
        self._lower_read = self._lower.copy()
        self._upper_read = self._upper.copy()
        self._lower_read[unbounded] = -np.inf
        self._upper_read[unbounded] = np.inf
        self._lower_read.flags.writeable = False
        self._upper_read.flags.writeable = False
        linear = np.isin(unbounded, np.asarray(linear_q, dtype=int))
        self._unbounded_angles = unbounded[~linear]
        self._unbounded_lengths = np.concatenate(
            [np.asarray(self._free_translations, dtype=int), unbounded[linear]]
        ).astype(int)

    def _posture_into_limits(self, q: FloatArray) -> FloatArray:
        """The default posture moved inside the joint limits (descriptions get this wrong).

        A revolute coordinate outside its limits is first shifted by a multiple of 2 pi (the
        same pose: an SRDF's ``-pi/2`` for a joint limited to ``[0.33, 5.95]``); what is still
        outside (and prismatic coordinates) is clipped, with a :class:`ModelWarning`.
        """
        idx = self._limited_q
        lo = self._lower[idx]
        hi = self._upper[idx]
        outside = np.flatnonzero((q[idx] < lo) | (q[idx] > hi))
        if outside.size == 0:
            return q
        q = q.copy()
        clipped: list[str] = []
        for k in outside:
            i = int(idx[k])
            value = q[i]
            if i not in self._linear_q:
                turns = math.ceil((lo[k] - value) / (2 * math.pi))
                shifted = value + 2 * math.pi * turns
                if lo[k] <= shifted <= hi[k]:
                    q[i] = shifted
                    continue
            q[i] = min(max(value, lo[k]), hi[k])
            clipped.append(f"{self._joint_name_at_q(i)}={value:.4g} -> {q[i]:.4g}")
        if clipped:
            warnings.warn(
                f"robot '{self.name}': the default posture is outside the joint limits; "
                f"clipped: {', '.join(clipped)}",
                ModelWarning,
                stacklevel=4,
            )
        return q

    def _warn_equal_limits(self) -> None:
        """A :class:`ModelWarning` naming the joints whose lower and upper limits are equal."""
        lower = np.asarray(self._model.lowerPositionLimit)
        upper = np.asarray(self._model.upperPositionLimit)
        equal = [
            f"{self._joint_name_at_q(int(i))}={lower[i]:.4g}"
            for i in np.flatnonzero(np.isfinite(lower) & (lower == upper))
        ]
        if equal:
            warnings.warn(
                f"robot '{self.name}': joints with equal lower and upper limits "
                f"({', '.join(equal)}) are treated as unlimited (a URDF's missing limits are "
                "0, 0); to hold a joint at one value, lock it (locked_joints=[...])",
                ModelWarning,
                stacklevel=4,
            )

    def _setup_actuation_limits(self, passive_joints: Sequence[str]) -> None:
        """Effort and velocity limits, with the documented choice for missing ones."""
        model = self._model
        for j in passive_joints:
            self.joint_id(j)
        passive = set(passive_joints)
        effort = np.asarray(model.effortLimit, dtype=float).copy()
        velocity = np.asarray(model.velocityLimit, dtype=float).copy()
        no_effort: list[str] = []
        no_velocity: list[str] = []
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            if joint.nv == 0:
                continue
            block = slice(joint.idx_v, joint.idx_v + joint.nv)
            jname = str(model.names[jid])
            if joint.shortname() == "JointModelFreeFlyer":
                effort[block] = 0.0  # a floating base is never actuated
                velocity[block] = np.inf
                continue
            if jname in passive:
                effort[block] = 0.0
            elif np.any(~(effort[block] > 0)):
                no_effort.append(jname)
                effort[block] = np.where(effort[block] > 0, effort[block], np.inf)
            if np.any(~(velocity[block] > 0)):
                no_velocity.append(jname)
                velocity[block] = np.where(velocity[block] > 0, velocity[block], np.inf)
        if no_effort:
            warnings.warn(
                f"robot '{self.name}': joints {no_effort} have no effort limit (0 or missing in "
                "the description); they are treated as actuated without torque limit. Declare "
                "really unactuated joints with passive_joints=[...].",
                ModelWarning,
                stacklevel=4,
            )
        if no_velocity:
            warnings.warn(
                f"robot '{self.name}': joints {no_velocity} have no velocity limit (0 or "
                "missing in the description); they are treated as unlimited (inf).",
                ModelWarning,
                stacklevel=4,
            )
        self.passive_joints = tuple(j for j in self._joint_ids if j in passive)
        self._effort_limits = effort
        self._velocity_limits = velocity
        self._effort_limits.flags.writeable = False
        self._velocity_limits.flags.writeable = False

    def _setup_massless_joints(self, stacklevel: int = 3) -> None:
        """Give joints that move no mass a small armature (see the module docstring).

        Starts from the model's own armature (``_model_armature``: what the description or
        the last :meth:`edit_model` gave, without what this rule added), so the rule gives
        the same robot on load and after an edit.
        """
        model = self._model
        model.armature = self._model_armature.copy()
        M = pin.crba(model, model.createData(), self._q_default)
        diagonal = np.diag(M).copy()
        scale = float(np.max(diagonal)) if diagonal.size else 0.0
        empty = diagonal <= 1e-12 * max(scale, 1.0)
        names: list[str] = []
        if np.any(empty) and np.any(~empty):
            armature = np.asarray(model.armature, dtype=float).copy()
            added = 0.01 * float(np.min(diagonal[~empty]))
            for jid in range(1, model.njoints):
                joint = model.joints[jid]
                block = slice(joint.idx_v, joint.idx_v + joint.nv)
                if joint.nv and np.any(empty[block]):
                    names.append(str(model.names[jid]))
                    armature[block] = np.where(empty[block], added, armature[block])
            model.armature = armature
            warnings.warn(
                f"robot '{self.name}': joints {names} move no mass (zero diagonal of the mass "
                f"matrix: forward dynamics would be undefined); they get a rotor inertia "
                f"(armature) of {added:.3g} kg m^2 (1 % of the smallest other diagonal entry)",
                ModelWarning,
                stacklevel=stacklevel,
            )
        self.massless_joints = tuple(names)

    @property
    def nq(self) -> int:
        """Size of the configuration vector."""
        return int(self._model.nq)

    @property
    def nv(self) -> int:
        """Size of the velocity (tangent) vector."""
        return int(self._model.nv)

    @property
    def frame_names(self) -> list[str]:
        """Names of all frames."""
        return list(self._frame_ids)

    @property
    def joint_names(self) -> list[str]:
        """Names of all joints except the universe."""
        return list(self._joint_ids)

    def frame_id(self, name: str) -> int:
        """Index of the frame called ``name``; the error lists the valid frames."""
        try:
            return self._frame_ids[name]
        except (KeyError, TypeError):  # TypeError: an unhashable name such as ['tool0']
            shown = name if isinstance(name, str) else repr(name)
            raise UnknownNameError("frame", shown, self._frame_ids) from None

    def joint_id(self, name: str) -> int:
        """Index of the joint called ``name``; the error lists the valid joints."""
        try:
            return self._joint_ids[name]
        except (KeyError, TypeError):  # TypeError: an unhashable name such as ['joint1']
            shown = name if isinstance(name, str) else repr(name)
            raise UnknownNameError("joint", shown, self._joint_ids) from None

    def joint_v_index(self, name: str) -> int:
        """First index of joint ``name`` in the velocity vector."""
        return int(self._model.joints[self.joint_id(name)].idx_v)

    @property
    def limited_joints_q(self) -> np.ndarray:
        """Configuration indices of the joint coordinates (nq = nv joints) with finite limits."""
        return self._limited_q

    @property
    def limited_joints_v(self) -> np.ndarray:
        """Velocity indices matching :attr:`limited_joints_q`."""
        return self._limited_v

    @property
    def lower_limits(self) -> FloatArray:
        """Lower position limits (size nq, read-only) [rad or m].

        ``-inf`` on the joint coordinates the robot treats as unlimited: no limits, equal
        limits (a URDF's missing ``(0, 0)``, warned about on load) or a span of ``1e10`` or
        more; the model's own value elsewhere (Pinocchio's on free-flyer and planar entries).
        """
        return self._lower_read

    @property
    def upper_limits(self) -> FloatArray:
        """Upper position limits (size nq, read-only) [rad or m]; ``+inf`` where unlimited.

        See :attr:`lower_limits`.
        """
        return self._upper_read

    @property
    def version(self) -> int:
        """Model version: changes at every :meth:`set_limits` and :meth:`edit_model`."""
        return self._version

    # ------------------------------------------------------------------ Pinocchio objects
    @property
    def model(self) -> pin.Model:
        """A read-only copy of the robot's ``pin.Model``.

        The robot makes the copy after each change (:meth:`set_limits`, :meth:`edit_model`)
        and hands out the same object until the next one (an integer comparison), so
        ``pin.integrate(robot.model, q, dq)`` in a loop costs what it did. Do not edit it:
        an edit changes nothing of the robot or of the objects built from it (use
        :meth:`edit_model` or :meth:`set_limits`), and later reads of ``robot.model`` would
        show it until the robot changes; ``robot.model.copy()`` gives a model of your own.
        Views into the copy (``model.lowerPositionLimit``, ``referenceConfigurations[...]``)
        are valid while you hold it (``model = robot.model``).
        """
        copy = self._model_copy
        if copy is None or self._model_copy_version != self._version:
            copy = self._model_copy = self._model.copy()
            self._model_copy_version = self._version
        return copy

    @property
    def collision_model(self) -> pin.GeometryModel:
        """A read-only copy of the robot's collision ``pin.GeometryModel`` (robot + obstacles).

        Handed out as :attr:`model` is: a new copy after each change of the robot's world
        (obstacles, collision pairs, :meth:`edit_collision_model`, :meth:`edit_model`), the
        same object in between. Do not edit it (an edit changes nothing of the robot: use
        :meth:`edit_collision_model`, the obstacle and collision-pair methods). Its coal shapes
        are clones of the robot's, so a shape modified in place (``geometry.halfSide[:] = ...``,
        ``geometry.radius = ...``, a mesh's ``vertices()``) does not reach the robot either.
        Clones of meshes (BVH models, convex polytopes, height fields, octrees) are made once
        and given to the later copies while they equal the robot's shape (coal's ``==``), so
        such a renewal costs a comparison of the meshes instead of their clone (primitives are
        cloned each time).
        """
        copy = self._collision_copy
        stamp = (self.world.version, self._geometry_edits)
        if copy is None or self._collision_copy_stamp != stamp:
            copy = self._collision_model.copy()
            self._shape_clones = _clone_shapes(copy, self._shape_clones)
            self._collision_copy = copy
            self._collision_copy_stamp = stamp
        return copy

    @property
    def visual_model(self) -> pin.GeometryModel:
        """A read-only copy of the robot's visual ``pin.GeometryModel`` (display only).

        Made once (the visual model never changes) and handed out each time: do not edit it.
        """
        copy = self._visual_copy
        if copy is None:  # the visual model never changes
            copy = self._visual_copy = self._visual_model.copy()
        return copy

    @property
    def data(self) -> pin.Data:
        """The robot's own ``pin.Data``: scratch space of :meth:`frame_placement`.

        A read-only attribute: evaluate into a :class:`~taskspace.model.State` or your own
        ``robot.model.createData()`` instead.
        """
        return self._data

    @property
    def collision_data(self) -> pin.GeometryData:
        """The robot's own ``pin.GeometryData`` (read-only attribute).

        Scratch space of :meth:`is_collision_free` and :meth:`colliding_pairs`, made at its
        first use after each change of the collision model (obstacles, pairs, edits): a new
        object then.
        """
        with _DATA_LOCK:
            return self._own_collision_data()

    def _own_collision_data(self) -> Any:
        """The robot's collision data, made now if the collision model changed (hold _DATA_LOCK)."""
        data = self._collision_data
        if data is None:
            data = self._collision_data = self._collision_model.createData()
        return data

    @contextlib.contextmanager
    def edit_model(self) -> Iterator[pin.Model]:
        """Edit the values of the robot's ``pin.Model``; the robot gets a new :attr:`version`.

        Example::

            with robot.edit_model() as model:
                model.inertias[3] = pin.Inertia(2.0, model.inertias[3].lever, ...)
                model.jointPlacements[2].translation[2] += 0.01

        The block receives a copy of the model. When it ends without an exception, the
        edits are checked and written into the robot's model; the robot gets a new
        :attr:`version` and its world a new :attr:`~taskspace.model.World.version`, so every
        object built from the robot (states, constraints, IK and inverse-dynamics solvers,
        their compiled kernels, collision checkers, configuration spaces, planners) computes
        with the new values or raises :class:`StaleModelError`. Every live
        :class:`~taskspace.model.State` of the robot is re-evaluated at its configuration
        and velocity with the new values (its kinematics never predate the edit). An
        exception in the block leaves the robot unchanged.

        Editable: ``jointPlacements``, ``inertias``, each frame's ``placement`` and
        ``inertia``, ``armature``, ``damping``, ``friction``, ``rotorInertia``,
        ``rotorGearRatio``, ``gravity``, and the limits ``lowerPositionLimit``,
        ``upperPositionLimit``, ``velocityLimit``, ``effortLimit`` (checked as
        :meth:`set_limits` checks them).

        The rule for joints that move no mass (module docstring) runs again on the edited
        values, so the robot is the one a model with these values loads as: a joint made
        massless (its bodies' inertias zero, or its armature set to 0) gets the rule's
        armature and is listed in :attr:`massless_joints`; an armature the rule added goes
        back to the model's own value when the joint moves mass again (unless the edit set
        that entry).

        Raises:
            InvalidInputError: anything else changed (joints, frames, names, parents, sizes,
                other fields: build a new :class:`Robot`), or limits :meth:`set_limits`
                refuses. The robot is then unchanged.
        """
        edited = self._model.copy()
        yield edited
        self._adopt_model(edited)

    def _adopt_model(self, edited: Any) -> None:
        """Check an edited copy of the model (values only) and write it into ours."""
        if not isinstance(edited, pin.Model):
            raise InvalidInputError(f"edit_model: the model was replaced by {edited!r}")
        original = self._model
        candidate = original.copy()
        _copy_model_values(edited, candidate)
        if candidate != edited:
            raise InvalidInputError(
                f"robot '{self.name}': edit_model changed more than values: only "
                f"{', '.join(_EDITABLE_MODEL_FIELDS)} and the frames' placement and inertia "
                "may change (joints, frames, names, parents and sizes need a new Robot, e.g. "
                "Robot.from_urdf); the robot is unchanged"
            )
        limits: dict[str, Any] = {}
        for key, field in (
            ("lower", "lowerPositionLimit"),
            ("upper", "upperPositionLimit"),
            ("velocity", "velocityLimit"),
            ("effort", "effortLimit"),
        ):
            value = np.asarray(getattr(edited, field), dtype=float)
            if not np.array_equal(value, np.asarray(getattr(original, field))):
                limits[key] = value
        if limits:
            self.set_limits(**limits)  # checks them all before it writes anything
        # the massless-joint rule runs again from the model's own armature: an entry the
        # rule added and the edit left alone is the model's value again (as on load)
        current = np.asarray(original.armature, dtype=float)
        requested = np.asarray(edited.armature, dtype=float)
        added_by_rule = current != self._model_armature
        untouched = requested == current
        _copy_model_values(edited, original)
        self._model_armature = np.where(added_by_rule & untouched, self._model_armature, requested)
        self._setup_massless_joints(stacklevel=5)
        self._data = original.createData()
        self._version = next(_ROBOT_VERSIONS)
        self.world.mark_changed()  # collision answers depend on the kinematics
        for state in list(self._states):  # kinematics of the old values: re-evaluated
            state._refresh()

    @contextlib.contextmanager
    def edit_collision_model(self) -> Iterator[pin.GeometryModel]:
        """Edit the robot's collision geometry and pairs; its world gets a new version.

        Example::

            with robot.edit_collision_model() as geom:
                gid = geom.getGeometryId("panda_link7_0")
                geom.geometryObjects[gid].placement = pin.SE3(...)
                geom.removeCollisionPair(pin.CollisionPair(a, b))

        The block receives a copy of the collision model. When it ends without an exception,
        the edits are checked and written into the robot's model and its world gets a new
        :attr:`~taskspace.model.World.version`, which every collision checker,
        configuration space, planner, state and collision feature follows. An exception in
        the block leaves the robot unchanged.

        The block's copy holds clones of the robot's shapes: a shape may be modified in place
        in the block (``geom.geometryObjects[i].geometry.radius = ...``) or replaced; what
        is written into the robot is a clone of each changed shape, so the shapes the block
        saw stay the caller's.

        Editable: each robot geometry's ``placement``, ``geometry`` (a new coal shape),
        ``disableCollision``, ``meshScale``, ``meshColor``, ``meshPath``, ``meshMaterial``,
        ``meshTexturePath``, ``overrideMaterial``, and the collision pairs (any, obstacle
        pairs included).

        Raises:
            InvalidInputError: geometries added, removed, renamed or moved to another joint or
                frame, or an obstacle changed (use :meth:`add_obstacle` and
                :meth:`remove_obstacle`). The robot is then unchanged.
        """
        edited = self._collision_model.copy()
        _clone_shapes(edited)  # shapes modified in place in the block stay out of the robot
        yield edited
        self._adopt_collision_model(edited)

    def _adopt_collision_model(self, edited: Any) -> None:
        """Check an edited copy of the collision model and write it into ours."""
        if not isinstance(edited, pin.GeometryModel):
            raise InvalidInputError(f"edit_collision_model: the model was replaced by {edited!r}")
        original = self._collision_model
        objs, new = original.geometryObjects, edited.geometryObjects
        problem = ""
        if edited.ngeoms != original.ngeoms:
            problem = f"{original.ngeoms} geometries became {edited.ngeoms}"
        else:
            for i in range(original.ngeoms):
                a, b = objs[i], new[i]
                if (a.name, a.parentJoint, a.parentFrame) != (b.name, b.parentJoint, b.parentFrame):
                    problem = f"geometry {i} '{a.name}' was renamed or moved to another joint"
                    break
                if i >= self._robot_geometry_count and a != b:
                    problem = f"obstacle '{a.name}' changed (remove it and add the new one)"
                    break
        if not problem:
            candidate = original.copy()
            _copy_geometry_values(edited, candidate, self._robot_geometry_count)
            if candidate != edited:
                problem = "fields other than the editable ones changed"
        if problem:
            raise InvalidInputError(
                f"robot '{self.name}': edit_collision_model: {problem}; the robot is unchanged"
            )
        _copy_geometry_values(edited, original, self._robot_geometry_count)
        self._geometry_edits += 1
        self._collision_data = None
        self.world.mark_changed()

    def check_version(self, built_version: int, owner: str) -> None:
        """Raise :class:`StaleModelError` unless ``built_version`` is the current version.

        Args:
            built_version: the :attr:`version` an object recorded when it was built.
            owner: what the object is, for the message (``"JointPositionLimits"``...).
        """
        if built_version != self._version:
            raise StaleModelError(
                f"{owner} was built for version {built_version} of robot '{self.name}', whose "
                "model has changed since (Robot.set_limits or Robot.edit_model, now version "
                f"{self._version}); "
                f"build a new {owner}",
                built_version,
                self._version,
            )

    def set_limits(
        self,
        *,
        lower: Any = None,
        upper: Any = None,
        velocity: Any = None,
        effort: Any = None,
    ) -> int:
        """Change joint limits (the only way to change them); the robot gets a new version.

        Objects built before (constraints, features, solvers, planning spaces) see the new
        :attr:`version` and rebuild or raise :class:`StaleModelError`.

        Args:
            lower: lower position limits (size nq) [rad or m], ``-inf`` where unlimited.
            upper: upper position limits (size nq) [rad or m], ``+inf`` where unlimited;
                ``lower < upper``. A floating base's seven entries stay ``-inf``/``+inf``.
            velocity: velocity limits (size nv, ``>= 0``) [rad/s or m/s], ``inf`` where
                unlimited.
            effort: effort limits (size nv, ``>= 0``) [N m or N]; 0 makes a coordinate
                unactuated. A floating base's six entries stay 0.

        Returns:
            The new :attr:`version`.

        Raises:
            ShapeError: wrong sizes.
            InvalidInputError: NaN, ``lower > upper``, ``lower == upper`` where the limits
                change (equal limits mean "no limit": lock a joint to hold it), negative
                velocity or effort limits, a limited floating base or an actuated one.
        """
        model = self._model
        new_lower = self._lower if lower is None else self._limit_array(lower, self.nq, "lower")
        new_upper = self._upper if upper is None else self._limit_array(upper, self.nq, "upper")
        bad = np.flatnonzero(new_lower > new_upper)
        if bad.size:
            raise InvalidInputError(
                f"lower limits above upper limits at configuration indices {bad[:10].tolist()}"
            )
        # lower == upper reads as "no limit given" (a URDF's default 0, 0): a range set here
        # must be wider, or the joint would silently become unlimited
        pinned = np.flatnonzero(
            (new_lower == new_upper) & ((new_lower != self._lower) | (new_upper != self._upper))
        )
        if pinned.size:
            names = sorted({self._joint_name_at_q(int(i)) for i in pinned})
            raise InvalidInputError(
                f"lower == upper at configuration indices {pinned[:10].tolist()} (joints "
                f"{', '.join(names)}): equal limits mean 'no limit' to taskspace (a URDF's "
                "missing limits are 0, 0); give a range (lower < upper), or lock the joint "
                "to hold it at one value (Robot.load/from_urdf locked_joints, "
                "taskspace.planning.LockedJoints)"
            )
        new_velocity = (
            self._velocity_limits
            if velocity is None
            else self._limit_array(velocity, self.nv, "velocity", nonnegative=True)
        )
        new_effort = (
            self._effort_limits
            if effort is None
            else self._limit_array(effort, self.nv, "effort", nonnegative=True)
        )
        if self.is_floating:
            if np.any(np.isfinite(new_lower[:7])) or np.any(np.isfinite(new_upper[:7])):
                raise InvalidInputError(
                    "the floating base (q[0:7]) is unlimited: keep -inf/inf there (bound the "
                    "base of a planner with its own options)"
                )
            if np.any(new_effort[:6] != 0.0):
                raise InvalidInputError("the floating base is not actuated: keep effort[0:6] = 0")
        model.lowerPositionLimit = new_lower.copy()
        model.upperPositionLimit = new_upper.copy()
        model.velocityLimit = new_velocity.copy()
        model.effortLimit = new_effort.copy()
        self._setup_joint_structure()
        self._velocity_limits = new_velocity.copy()
        self._effort_limits = new_effort.copy()
        self._velocity_limits.flags.writeable = False
        self._effort_limits.flags.writeable = False
        self.passive_joints = tuple(
            jname
            for jname, jid in self._joint_ids.items()
            if model.joints[jid].nv
            and model.joints[jid].shortname() != "JointModelFreeFlyer"
            and not np.any(
                new_effort[model.joints[jid].idx_v : model.joints[jid].idx_v + model.joints[jid].nv]
            )
        )
        q_default = self._posture_into_limits(self._q_default)
        q_default.flags.writeable = False
        self._q_default = q_default
        self._version = next(_ROBOT_VERSIONS)
        return self._version

    @staticmethod
    def _limit_array(value: Any, size: int, name: str, *, nonnegative: bool = False) -> FloatArray:
        arr = as_float_array(value, f"{name} limits")
        if arr.shape != (size,):
            raise ShapeError(f"{name} limits", (size,), tuple(arr.shape))
        if np.any(np.isnan(arr)):
            raise InvalidInputError(f"{name} limits have NaN entries")
        if nonnegative and np.any(arr < 0.0):
            bad = np.flatnonzero(arr < 0.0)[:10].tolist()
            raise InvalidInputError(
                f"{name} limits must be >= 0 (inf: unlimited); negative at {bad}"
            )
        return np.array(arr, dtype=np.float64)

    @property
    def velocity_limits(self) -> FloatArray:
        """Velocity limits (size nv) [rad/s or m/s]; inf where unlimited or unknown.

        The floating base is unlimited; a limit of 0 in the description is read as unknown.
        """
        return self._velocity_limits.copy()

    @property
    def effort_limits(self) -> FloatArray:
        """Torque/force limits (size nv) [N m or N].

        0 on unactuated coordinates (floating base, :attr:`passive_joints`); inf where the
        description gives none (0 or missing) for another joint.
        """
        return self._effort_limits.copy()

    @property
    def q_default(self) -> FloatArray:
        """Default posture (read-only)."""
        return self._q_default

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        return float(pin.computeTotalMass(self._model))

    # ------------------------------------------------------------------ configurations
    def check_configuration(self, q: Any, name: str = "q") -> FloatArray:
        """Validate a configuration: shape (nq,), finite, unit quaternions.

        Returns:
            A float64 copy of ``q``.

        Raises:
            ShapeError, NotFiniteError: wrong shape or NaN/inf.
            InvalidInputError: a quaternion (or unit complex of a continuous joint) is not
                normalized; use :meth:`normalize`.
        """
        if type(q) is np.ndarray and q.dtype is _F64 and q.shape == self._q_shape:
            arr = q.copy()  # fast path for the common case
            if not math.isfinite(arr.dot(self._q_tiny)):
                check_finite(arr, name)
        else:
            arr = as_vector(q, self._nq, name)
            arr = arr.copy() if arr is q else arr
        if not self._normalized_blocks or pin.isNormalized(self._model, arr, QUATERNION_TOLERANCE):
            return arr
        for idx, size, joint in self._normalized_blocks:
            block = arr[idx : idx + size]
            norm = math.sqrt(block.dot(block))
            if abs(norm - 1.0) > QUATERNION_TOLERANCE:
                kind = "quaternion" if size == 4 else "unit complex (cos, sin)"
                raise InvalidInputError(
                    f"{name}[{idx}:{idx + size}] is the {kind} of joint '{joint}' and must have "
                    f"unit norm, got {norm:.9g}; call robot.normalize(q)"
                )
        return arr

    def check_velocity(self, v: Any, name: str = "v") -> FloatArray:
        """Validate a tangent vector: shape (nv,), finite. Returns a float64 copy."""
        if type(v) is np.ndarray and v.dtype is _F64 and v.shape == self._v_shape:
            arr = v.copy()
            if not math.isfinite(arr.dot(self._v_tiny)):
                check_finite(arr, name)
            return arr
        arr = as_vector(v, self._nv, name)
        return arr.copy() if arr is v else arr

    def check_limits(self, q: Any, *, tolerance: float = 0.0, name: str = "q") -> FloatArray:
        """Validate ``q`` and raise :class:`LimitError` if a joint is outside its limits."""
        arr = self.check_configuration(q, name)
        idx = self._limited_q
        lo = self._lower[idx] - tolerance
        hi = self._upper[idx] + tolerance
        bad = np.flatnonzero((arr[idx] < lo) | (arr[idx] > hi))
        if bad.size:
            qi = idx[bad]
            names = [self._joint_name_at_q(int(i)) for i in qi]
            details = ", ".join(
                f"{n}={arr[i]:.4g} not in [{self._lower[i]:.4g}, {self._upper[i]:.4g}]"
                for n, i in zip(names, qi)
            )
            raise LimitError(
                f"{name} is outside the joint limits: {details}",
                [int(i) for i in qi],
                arr[qi],
                self._lower[qi],
                self._upper[qi],
            )
        return arr

    def _joint_name_at_q(self, idx_q: int) -> str:
        for jid in range(1, self._model.njoints):
            joint = self._model.joints[jid]
            if joint.idx_q <= idx_q < joint.idx_q + joint.nq:
                return str(self._model.names[jid])
        return f"q[{idx_q}]"

    def normalize(self, q: Any) -> FloatArray:
        """``q`` with its quaternions and ``(cos, sin)`` pairs normalized (``pin.normalize``).

        Raises:
            InvalidInputError: a block is zero (no direction to normalize to).
        """
        arr = as_vector(q, self._model.nq, "q")
        for idx, size, joint in self._normalized_blocks:
            if not np.linalg.norm(arr[idx : idx + size]) > 1e-12:
                raise InvalidInputError(
                    f"q[{idx}:{idx + size}] of joint '{joint}' is zero and cannot be normalized"
                )
        return np.asarray(pin.normalize(self._model, arr))

    def neutral(self) -> FloatArray:
        """The neutral configuration (``pin.neutral``: zero angles, identity rotations)."""
        return np.asarray(pin.neutral(self._model))

    def random_configuration(
        self, rng: np.random.Generator, *, base_box: float = 1.0
    ) -> FloatArray:
        """Uniform random configuration within the joint limits.

        Coordinates with finite limits are uniform between them; unbounded revolute and
        continuous joints are uniform in angle on ``[-pi, pi)``; spherical joints and
        floating-base orientations are uniform on SO(3) (normalized Gaussian quaternion);
        unbounded translations (free-flyer, planar, prismatic without limits) are uniform in
        ``[-base_box, base_box]``.

        Args:
            rng: random generator.
            base_box: half side of the box of unbounded translations [m].
        """
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy Generator (np.random.default_rng(seed)), got {rng!r}"
            )
        base_box = check_positive(base_box, "base_box")
        q = np.asarray(pin.neutral(self._model)).copy()
        lo = self._lower
        hi = self._upper
        idx = self._limited_q
        q[idx] = rng.uniform(lo[idx], hi[idx])
        for start, size, _ in self._normalized_blocks:
            if size == 2:
                angle = rng.uniform(-np.pi, np.pi)
                q[start : start + 2] = (math.cos(angle), math.sin(angle))
            else:
                x = rng.normal(size=4)
                q[start : start + 4] = x / np.linalg.norm(x)
        # (this order keeps the random stream of earlier versions on fixed and floating bases)
        if self._unbounded_lengths.size:
            q[self._unbounded_lengths] = rng.uniform(
                -base_box, base_box, self._unbounded_lengths.size
            )
        if self._unbounded_angles.size:
            q[self._unbounded_angles] = rng.uniform(-np.pi, np.pi, self._unbounded_angles.size)
        return q

    def interpolate(self, q0: Any, q1: Any, t: float) -> FloatArray:
        """Configuration a fraction ``t`` of the way from ``q0`` to ``q1`` on the manifold.

        ``q(t) = q0 (+) t (q1 (-) q0)`` by :func:`interpolate_configurations`, the
        interpolation of the robot and of the planners (and their certification): geodesic
        on rotations, the shorter way round on continuous joints (either way between opposite
        angles, where ``pin.interpolate`` stays at ``q0``), straight on the other coordinates.

        Args:
            q0: start configuration.
            q1: end configuration.
            t: fraction in [0, 1] (values outside extrapolate along the same geodesic).
        """
        a = self.check_configuration(q0, "q0")
        b = self.check_configuration(q1, "q1")
        if not (isinstance(t, (int, float, np.floating, np.integer)) and math.isfinite(t)):
            raise InvalidInputError(f"t must be a finite number, got {t!r}")
        return interpolate_configurations(
            self._model, a, b, np.array([float(t)]), self._continuous
        )[0]

    def distance(self, q0: Any, q1: Any) -> float:
        """Length of the tangent vector from ``q0`` to ``q1``: ``||q1 (-) q0||`` [rad and m].

        Unweighted Euclidean norm of ``pin.difference``: angles in radians, translations in
        meters, rotations of spherical/free-flyer joints by their angle.
        """
        return float(np.linalg.norm(self.difference(q0, q1)))

    def integrate(self, q: Any, v: Any, dt: float = 1.0) -> FloatArray:
        """Configuration reached from ``q`` moving with velocity ``v`` for ``dt`` [s].

        Raises:
            InvalidInputError: ``dt`` is not a finite number.
            NotFiniteError: ``v * dt`` overflows (the configuration would hold inf or NaN).
        """
        qa = self.check_configuration(q)
        va = self.check_velocity(v)
        step = dt if dt.__class__ is float and math.isfinite(dt) else as_scalar(dt, "dt")
        with np.errstate(over="ignore"):  # an overflow is the error below, not a warning
            out = np.asarray(pin.integrate(self._model, qa, va * step))
        check_finite(out, "the integrated configuration (v * dt overflows)")
        return out

    def difference(self, q0: Any, q1: Any) -> FloatArray:
        """Tangent vector ``v`` such that ``integrate(q0, v) = q1``.

        :func:`configuration_difference`: ``pin.difference`` on the normalized
        configurations, with each continuous joint's angle by ``atan2`` (Pinocchio's gives 0
        for nearby angles whose unit complex is off unit norm by rounding-size amounts, e.g.
        1e-7).
        """
        a = self.check_configuration(q0, "q0")
        b = self.check_configuration(q1, "q1")
        if not self._normalized_blocks:  # vector joints only: q1 - q0, Pinocchio's arithmetic
            return np.asarray(pin.difference(self._model, a, b))
        return configuration_difference(self._model, a, b, self._continuous)

    def state(self, q: Any = None, v: Any = None) -> State:
        """A :class:`~taskspace.model.state.State` at ``q`` (default posture if omitted)."""
        from taskspace.model.state import State

        return State(self, self._q_default if q is None else q, v)

    # ------------------------------------------------------------------ kinematics helpers
    def frame_placement(self, q: Any, frame: str) -> pin.SE3:
        """Pose of ``frame`` in the world at configuration ``q``."""
        fid = self.frame_id(frame)
        qa = self.check_configuration(q)
        with _DATA_LOCK:
            pin.framesForwardKinematics(self._model, self._data, qa)
            return self._data.oMf[fid].copy()

    # ------------------------------------------------------------------ world and collisions
    @property
    def robot_geometry_count(self) -> int:
        """Number of robot geometries (the first entries of ``collision_model``)."""
        return self._robot_geometry_count

    @property
    def world(self) -> World:
        """The robot's obstacles (also in ``collision_model``); a read-only attribute.

        Its ``add``, ``remove`` and ``clear`` are :meth:`add_obstacle`,
        :meth:`remove_obstacle` and :meth:`clear_obstacles`: the robot's collision model
        always holds exactly the world's obstacles.
        """
        return self._world

    def add_obstacle(self, obstacle: Obstacle) -> None:
        """Add a fixed obstacle; it is checked against every robot geometry."""
        self.add_obstacles((obstacle,))

    def add_obstacles(self, obstacles: Iterable[Obstacle]) -> None:
        """Add several obstacles (in order; those before an invalid one stay added).

        The collision data is made once for all of them, not once per obstacle.
        """
        model = self._collision_model
        objs = model.geometryObjects
        # the robot geometries on moving joints (each Python access to a geometry object is a
        # Boost call: read once for all obstacles)
        moving = [rid for rid in range(self._robot_geometry_count) if objs[rid].parentJoint != 0]
        try:
            for obstacle in obstacles:
                self._world._add(obstacle)
                # a clone: the obstacle's own shape modified in place cannot reach the robot
                shape = obstacle.geometry.clone()
                geom = pin.GeometryObject(obstacle.name, 0, 0, obstacle.placement, shape)
                geom.meshColor = np.asarray(obstacle.color, dtype=float)
                gid = model.addGeometryObject(geom)
                for rid in moving:
                    model.addCollisionPair(pin.CollisionPair(rid, gid))
        finally:  # the data will match the model, also after an invalid obstacle
            self._collision_data = None

    def remove_obstacle(self, name: str) -> Obstacle:
        """Remove the obstacle ``name`` (raises UnknownNameError listing the obstacles)."""
        obstacle = self._world._remove(name)
        self._collision_model.removeGeometryObject(name)
        self._collision_data = None
        return obstacle

    def clear_obstacles(self) -> None:
        """Remove every obstacle."""
        for obstacle in list(self.world):
            self._collision_model.removeGeometryObject(obstacle.name)
            self._world._remove(obstacle.name)
        self._collision_data = None

    def disable_collision_pairs(self, pairs: Iterable[tuple[str, str]]) -> None:
        """Stop checking pairs of robot geometries (names as in :attr:`collision_pairs`).

        The world gets a new :attr:`~taskspace.model.World.version`, so every collision
        checker, configuration space and planner built before follows the change. Change
        pairs this way: edits of ``robot._collision_model`` in place (Pinocchio's
        ``removeCollisionPair``...) carry no version, and objects built before keep their
        copies.

        Raises:
            UnknownNameError: a name that is not a robot geometry (obstacle pairs follow the
                obstacles: remove the obstacle instead).
            InvalidInputError: not a list of (name, name) pairs, or a geometry paired with
                itself.
        """
        self._edit_collision_pairs(pairs, enable=False)

    def enable_collision_pairs(self, pairs: Iterable[tuple[str, str]]) -> None:
        """Check pairs of robot geometries again (see :meth:`disable_collision_pairs`)."""
        self._edit_collision_pairs(pairs, enable=True)

    def _edit_collision_pairs(self, pairs: Iterable[tuple[str, str]], *, enable: bool) -> None:
        objs = self._collision_model.geometryObjects
        names = {objs[i].name: i for i in range(self._robot_geometry_count)}
        if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Iterable):
            raise InvalidInputError(
                f"pairs must be a list of (geometry name, geometry name), got {pairs!r}"
            )
        resolved = []
        for pair in pairs:
            if (
                not isinstance(pair, (tuple, list))
                or len(pair) != 2
                or not all(isinstance(n, str) for n in pair)
            ):
                raise InvalidInputError(
                    f"each pair must be (geometry name, geometry name), got {pair!r}"
                )
            ids = []
            for n in pair:
                if n not in names:
                    raise UnknownNameError("robot geometry", n, names)
                ids.append(names[n])
            if ids[0] == ids[1]:
                raise InvalidInputError(f"a geometry cannot be paired with itself: {pair!r}")
            resolved.append(pin.CollisionPair(min(ids), max(ids)))
        model = self._collision_model
        for cp in resolved:
            if enable and not model.existCollisionPair(cp):
                model.addCollisionPair(cp)
            elif not enable and model.existCollisionPair(cp):
                model.removeCollisionPair(cp)
        self._collision_data = None
        self.world.mark_changed()

    @property
    def collision_pairs(self) -> list[tuple[str, str]]:
        """Checked collision pairs as (geometry name, geometry name)."""
        objs = self._collision_model.geometryObjects
        return [
            (objs[p.first].name, objs[p.second].name) for p in self._collision_model.collisionPairs
        ]

    def _queried_collision_data(self) -> Any:
        """``collision_data`` with the cached GJK guess off (once per data, ~0.5 ms).

        Pinocchio's default requests can report a real penetration free after a query of the
        same pair at another configuration (see ``taskspace.model.collision_requests``); done
        here rather than at each world change so that adding obstacles stays cheap.
        """
        data = self._own_collision_data()
        if self._guess_reset is not data:
            self._guess_reset = without_cached_guess(data)
        return data

    def is_collision_free(self, q: Any) -> bool:
        """True if no checked pair (self or world) collides at ``q``; stops at the first hit."""
        qa = self.check_configuration(q)
        with _DATA_LOCK:
            data = self._queried_collision_data()
            return not pin.computeCollisions(
                self._model, self._data, self._collision_model, data, qa, True
            )

    def colliding_pairs(self, q: Any) -> list[tuple[str, str]]:
        """Names of all colliding pairs at ``q``."""
        qa = self.check_configuration(q)
        with _DATA_LOCK:  # another thread's query would overwrite the results being read
            data = self._queried_collision_data()
            pin.computeCollisions(self._model, self._data, self._collision_model, data, qa, False)
            hits = [k for k, r in enumerate(data.collisionResults) if r.isCollision()]
        objs = self._collision_model.geometryObjects
        pairs = self._collision_model.collisionPairs
        return [(objs[pairs[k].first].name, objs[pairs[k].second].name) for k in hits]

    def __repr__(self) -> str:
        return (
            f"Robot('{self.name}', nq={self.nq}, nv={self.nv}, floating={self.is_floating}, "
            f"geometries={self._collision_model.ngeoms}, "
            f"pairs={len(self._collision_model.collisionPairs)}, obstacles={len(self.world)})"
        )


# ---------------------------------------------------------------------- helpers
BASES = ("fixed", "planar", "free_flyer")
"""Root joints :meth:`Robot.load` and :meth:`Robot.from_urdf` build (``base=``)."""


def continuous_joint_indices(model: pin.Model) -> tuple[IntArray, IntArray]:
    """``(idx_q, idx_v)`` of every continuous joint (its ``(cos, sin)`` pair and its angle)."""
    joints = [
        j
        for j in model.joints[1:]
        if j.shortname() in _UNIT_COMPLEX_JOINTS
        or j.shortname() == "JointModelRevoluteUnboundedUnaligned"
    ]
    return (
        np.array([j.idx_q for j in joints], dtype=np.int64),
        np.array([j.idx_v for j in joints], dtype=np.int64),
    )


def interpolate_configurations(
    model: pin.Model,
    q0: FloatArray,
    q1: FloatArray,
    ts: FloatArray,
    continuous: tuple[IntArray, IntArray] | None = None,
) -> FloatArray:
    """``q0 (+) t_k (q1 (-) q0)`` for each fraction ``t_k``: rows of shape (len(ts), nq).

    The one interpolation of configurations in taskspace (:meth:`Robot.interpolate`, the
    planners' :class:`~taskspace.planning.joint_manifold.JointManifold`, certification):
    ``pin.integrate(q0, t pin.difference(q0, q1))`` on ``q0`` and ``q1`` normalized first
    (``pin.normalize``), for every joint type, the angle of each continuous joint taken as
    ``atan2(q0 x q1, q0 . q1)``. It equals ``pin.interpolate`` (to ~1e-13) except where
    Pinocchio's SO(2) logarithm is wrong:

    * opposite angles of a continuous joint: ``pin.interpolate`` stays at ``q0`` for every
      ``t`` while ``pin.difference`` says pi; here the joint turns (the positive way);
    * a unit complex ``(cos, sin)`` of a continuous or planar joint whose norm is not 1 to
      rounding (an input within the accepted 1e-6): Pinocchio's logarithm returns 0 (or pi)
      when ``q0 . q1 > 1`` (or ``< -1``), e.g. angles 1e-4 rad apart at norm ``1 + 1e-7``;
      normalizing first leaves that rounding only within ~2e-8 rad of 0 and pi, which the
      ``atan2`` removes for continuous joints (a planar joint keeps Pinocchio's SE(2)
      logarithm: its yaw is off by at most ~2e-8 rad there).

    Args:
        model: the Pinocchio model.
        q0: start configuration (size nq, unit parts normalized to 1e-6).
        q1: end configuration.
        ts: fractions (values outside [0, 1] extrapolate along the same geodesic).
        continuous: :func:`continuous_joint_indices` of ``model`` (found again if omitted).
    """
    a, delta = _normalized_difference(model, q0, q1, continuous)
    out = np.empty((ts.shape[0], int(model.nq)))
    for k, t in enumerate(ts.tolist()):
        out[k] = pin.integrate(model, a, t * delta)
    return out


def configuration_difference(
    model: pin.Model,
    q0: FloatArray,
    q1: FloatArray,
    continuous: tuple[IntArray, IntArray] | None = None,
) -> FloatArray:
    """``q1 (-) q0``: ``pin.difference`` on ``q0`` and ``q1`` normalized first, size nv.

    The difference of :func:`interpolate_configurations` (so ``interpolate(q0, q1, 1)`` is
    ``q0 (+) difference``), with each continuous joint's angle taken as ``atan2(q0 x q1, q0 .
    q1)``: Pinocchio's SO(2) logarithm returns 0 (or pi) for unit complexes within the accepted
    1e-6 of unit norm whose dot product rounds past 1 (or -1), e.g. angles 1e-4 rad apart at
    norm ``1 + 1e-7``.

    Args:
        model: the Pinocchio model.
        q0, q1: configurations (size nq, unit parts normalized to 1e-6).
        continuous: :func:`continuous_joint_indices` of ``model`` (found again if omitted).
    """
    return _normalized_difference(model, q0, q1, continuous)[1]


def _normalized_difference(
    model: pin.Model,
    q0: FloatArray,
    q1: FloatArray,
    continuous: tuple[IntArray, IntArray] | None,
) -> tuple[FloatArray, FloatArray]:
    """``(normalize(q0), configuration_difference(q0, q1))``."""
    a = np.asarray(pin.normalize(model, q0))
    b = np.asarray(pin.normalize(model, q1))
    delta = np.asarray(pin.difference(model, a, b))
    c, v = continuous_joint_indices(model) if continuous is None else continuous
    if c.size:
        delta[v] = np.arctan2(a[c] * b[c + 1] - a[c + 1] * b[c], a[c] * b[c] + a[c + 1] * b[c + 1])
    return a, delta


def _check_base(base: object) -> str | None:
    """``base`` validated: ``None`` or one of :data:`BASES`."""
    if base is None or (isinstance(base, str) and base in BASES):
        return base
    raise InvalidInputError(f"base must be None or one of {', '.join(BASES)}, got {base!r}")


def _is_plain_loader(loader: Any) -> bool:
    """True when an example-robot-data loader only reads a URDF (and SRDF) of its package."""
    from example_robot_data.utils import RobotLoader

    return bool(loader.urdf_filename) and loader.__init__ is RobotLoader.__init__


def _erd_paths(loader: Any) -> tuple[str, list[str], str | None]:
    """(URDF, package directories, SRDF or None) of a plain example-robot-data loader."""
    from os.path import join

    from example_robot_data.robots_loader import getModelPath

    df_path = join(loader.path, loader.urdf_subpath, loader.urdf_filename)
    try:
        model_path = loader.model_path or getModelPath(df_path)
    except OSError as exc:
        raise ModelLoadError(f"example-robot-data has no file {df_path}: {exc}") from exc
    urdf = join(model_path, df_path)
    srdf = None
    if loader.srdf_filename:
        srdf = join(model_path, loader.path, loader.srdf_subpath, loader.srdf_filename)
    return urdf, [join(model_path, "../.."), model_path], srdf


def _posture_from_spec(model: pin.Model, spec: RobotSpec, q: FloatArray) -> FloatArray:
    q = q.copy()
    posture = spec.default_posture
    if "srdf" in posture:
        ref = posture["srdf"]
        names = [
            str(k.key()) if hasattr(k, "key") else str(k) for k in model.referenceConfigurations
        ]
        if ref in names:
            q = np.asarray(model.referenceConfigurations[ref]).copy()
        elif posture.get("srdf_optional"):
            logger.info(
                "robot '%s': the SRDF has no reference configuration '%s' (it has: %s); "
                "default posture = neutral",
                spec.name,
                ref,
                ", ".join(names) or "none",
            )
        else:
            raise UnknownNameError("reference configuration", ref, names)
    joints = posture.get("joints", {}) or {}
    names_map = {n: i for i, n in enumerate(model.names)}
    for jname, value in joints.items():
        if jname not in names_map:
            raise ModelLoadError(
                f"registry entry '{spec.name}': default posture names unknown joint '{jname}'"
            )
        q[model.joints[names_map[jname]].idx_q] = float(value)
    if "base" in posture:
        q[:3] = np.asarray(posture["base"], dtype=float)
    check_finite(q, "default posture")
    return q


def _load_reference_configurations(model: pin.Model, srdf: Path) -> None:
    """Read the SRDF's reference configurations (``group_state``) into ``model``.

    As Pinocchio reads them, with a free-flyer root entry (7 values) adapted to the model's
    root. Descriptions of legged robots give their ``root_joint`` seven values (position and unit
    quaternion). A robot loaded with ``base="fixed"`` has no such joint and one loaded with
    ``base="planar"`` has a 4-coordinate one, and Pinocchio prints "Could not read joint
    config" on stderr for such an entry. The entry is taken out before Pinocchio reads the
    file; on a planar root it becomes ``(x, y, cos yaw, sin yaw)`` (the yaw of the quaternion);
    on a fixed base it is dropped (the base pose is not part of the configuration).
    """
    import xml.etree.ElementTree as ET

    tree = ET.parse(srdf)
    roots: dict[str, list[float]] = {}  # group_state name -> the root entry's seven values
    for state in tree.getroot().iter("group_state"):
        for joint in list(state.findall("joint")):
            name = joint.get("name", "")
            values = (joint.get("value") or "").split()
            if len(values) != 7:
                continue
            jid = model.getJointId(name) if model.existJointName(name) else None
            if jid is not None and model.joints[jid].nq == 7:
                continue  # a free flyer: Pinocchio reads it
            if jid is not None and model.joints[jid].shortname() != "JointModelPlanar":
                continue  # another joint: Pinocchio reports the mismatch as before
            if jid is None and model.existFrame(name):
                continue
            state.remove(joint)
            if jid is not None:
                roots[state.get("name", "")] = [float(v) for v in values]
    pin.loadReferenceConfigurationsFromXML(model, ET.tostring(tree.getroot(), "unicode"), False)
    for state_name, (x, y, _, qx, qy, qz, qw) in roots.items():
        if state_name not in model.referenceConfigurations:
            continue
        q = np.asarray(model.referenceConfigurations[state_name]).copy()
        norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        if not norm > 0.0:
            raise ModelLoadError(
                f"SRDF {srdf}: group_state '{state_name}' gives the root joint a zero quaternion"
            )
        qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
        yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        for jid in range(1, model.njoints):
            if model.joints[jid].shortname() == "JointModelPlanar":
                i = model.joints[jid].idx_q
                q[i : i + 4] = (x, y, math.cos(yaw), math.sin(yaw))
                break
        model.referenceConfigurations[state_name] = q


def _drop_orphan_geometries(
    model: pin.Model, geometry: pin.GeometryModel, name: str, kind: str
) -> None:
    """Remove geometries attached to joints or frames the model does not have.

    Pinocchio would read past the end of ``Data`` for them (example-robot-data's
    ``talos_legs`` keeps the collision geometry of the whole robot on a legs-only model).
    """
    orphans = [
        str(g.name)
        for g in geometry.geometryObjects
        if g.parentJoint >= model.njoints or g.parentFrame >= model.nframes
    ]
    for gname in orphans:
        geometry.removeGeometryObject(gname)
    if orphans:
        warnings.warn(
            f"robot '{name}': {len(orphans)} {kind} geometries are attached to joints or "
            f"frames the model does not have and were removed: {orphans[:8]}"
            + ("..." if len(orphans) > 8 else ""),
            ModelWarning,
            stacklevel=4,
        )


def _pair_names(collision: pin.GeometryModel, first: int, second: int) -> tuple[str, str]:
    objs = collision.geometryObjects
    return (str(objs[first].name), str(objs[second].name))


def _remove_adjacent_pairs(model: pin.Model, collision: pin.GeometryModel) -> list[tuple[str, str]]:
    """Drop the pairs of geometries on the same or adjacent joints; return their names."""
    objs = collision.geometryObjects
    parents = model.parents
    drop = []
    for pair in collision.collisionPairs:
        ja, jb = objs[pair.first].parentJoint, objs[pair.second].parentJoint
        if ja == jb or parents[ja] == jb or parents[jb] == ja:
            drop.append((int(pair.first), int(pair.second)))
    for first, second in drop:
        collision.removeCollisionPair(pin.CollisionPair(first, second))
    return [_pair_names(collision, a, b) for a, b in drop]


def prune_collision_pairs(
    robot: Robot,
    options: CollisionPruningOptions | None = None,
    *,
    adjacent: Sequence[tuple[str, str]] = (),
) -> PrunedCollisionPairs:
    """Disable the self-collision pairs that collide at the default posture or almost always.

    Rules (MoveIt setup assistant's "default" and "always"):

    * a pair in collision at ``robot.q_default`` is disabled;
    * a pair in collision in at least ``ceil(fraction * samples)`` of ``samples`` random
      configurations (:meth:`Robot.random_configuration`, seed ``options.seed``) is
      disabled. Each pair is dropped from the test once it has missed more than
      ``samples - ceil(fraction * samples)`` times, so the cost is a few full checks.

    Each disabled pair is reported with a :class:`ModelWarning`; the result is stored in
    ``robot.pruned_collision_pairs``. Only robot-robot pairs are considered (call before
    adding obstacles).

    Args:
        robot: the robot (its ``collision_model`` is modified).
        options: thresholds (default :class:`CollisionPruningOptions`).
        adjacent: pairs already disabled by the adjacency rule (recorded in the result).

    Returns:
        The disabled pairs by rule.
    """
    options = options or CollisionPruningOptions()
    model, collision = robot._model, robot._collision_model
    data = model.createData()
    geom_data = without_cached_guess(collision.createData())
    n_robot = robot.robot_geometry_count
    pairs = [
        (int(p.first), int(p.second))
        for p in collision.collisionPairs
        if p.first < n_robot and p.second < n_robot
    ]
    index = {(int(p.first), int(p.second)): k for k, p in enumerate(collision.collisionPairs)}

    def colliding(q: FloatArray, candidates: list[tuple[int, int]]) -> list[bool]:
        pin.updateGeometryPlacements(model, data, collision, geom_data, q)
        return [bool(pin.computeCollision(collision, geom_data, index[c])) for c in candidates]

    default: list[tuple[int, int]] = []
    if options.default_posture and pairs:
        hits = colliding(np.asarray(robot.q_default), pairs)
        default = [c for c, h in zip(pairs, hits) if h]
    remaining = [c for c in pairs if c not in set(default)]
    always: list[tuple[int, int]] = []
    if options.samples > 0 and remaining:
        rng = np.random.default_rng(options.seed)
        needed = math.ceil(options.fraction * options.samples - 1e-9)
        allowed_misses = options.samples - needed
        misses = dict.fromkeys(remaining, 0)
        candidates = list(remaining)
        for _ in range(options.samples):
            if not candidates:
                break
            hits = colliding(robot.random_configuration(rng), candidates)
            survivors = []
            for c, h in zip(candidates, hits):
                if not h:
                    misses[c] += 1
                if misses[c] <= allowed_misses:
                    survivors.append(c)
            candidates = survivors
        always = candidates
    kept = [c for c in remaining if c not in set(always)]  # (before the pairs are removed)
    rate_samples = min(_RATE_SAMPLES, options.samples) if kept else 0
    rate, common = _self_collision_rate(robot, geom_data, kept, index, rate_samples, options.seed)
    for first, second in default + always:
        collision.removeCollisionPair(pin.CollisionPair(first, second))
    robot._collision_data = None  # made again at its next use
    robot.world.mark_changed()  # the pairs changed (also what robot.collision_model hands out)
    result = PrunedCollisionPairs(
        adjacent=tuple(adjacent),
        default_posture=tuple(_pair_names(collision, a, b) for a, b in default),
        always=tuple(_pair_names(collision, a, b) for a, b in always),
        samples=options.samples,
        fraction=options.fraction,
        self_collision_rate=rate,
        rate_samples=rate_samples,
    )
    robot.pruned_collision_pairs = result
    if adjacent:
        logger.info(
            "robot '%s' has no SRDF: disabled %d collision pairs of adjacent links",
            robot.name,
            len(adjacent),
        )
    if result.default_posture or result.always:
        source = "its SRDF" if robot.srdf_path else "the adjacency rule"
        parts = []
        if result.default_posture:
            parts.append(f"in collision at the default posture: {list(result.default_posture)}")
        if result.always:
            parts.append(
                f"in collision in >= {options.fraction:.0%} of {options.samples} random "
                f"configurations: {list(result.always)}"
            )
        warnings.warn(
            f"robot '{robot.name}': collision pairs left by {source} were disabled, "
            + "; ".join(parts),
            ModelWarning,
            stacklevel=3,
        )
    if rate_samples and rate >= options.fraction:
        names = [_pair_names(collision, a, b) for a, b in common]
        warnings.warn(
            f"robot '{robot.name}': {rate:.0%} of {rate_samples} random configurations within "
            "the joint limits are in self-collision after pruning (no single pair reaches "
            f"{options.fraction:.0%}; most often in contact: {names}): sampling planners will "
            "find little free space. Check the collision geometry, disable pairs that cannot "
            "touch (an SRDF, or Robot.edit_collision_model), or narrow the joint limits "
            "(Robot.set_limits)",
            ModelWarning,
            stacklevel=3,
        )
    return result


# Random configurations of the self-collision estimate of prune_collision_pairs.
_RATE_SAMPLES = 20


def _self_collision_rate(
    robot: Robot,
    geom_data: pin.GeometryData,
    pairs: list[tuple[int, int]],
    index: dict[tuple[int, int], int],
    samples: int,
    seed: int,
) -> tuple[float, list[tuple[int, int]]]:
    """Fraction of ``samples`` random configurations with a pair of ``pairs`` in collision.

    Configurations from :meth:`Robot.random_configuration` with a generator of its own
    (``seed + 1``: other samples than the "always" rule's). Each configuration stops at its
    first colliding pair, so a robot that is mostly free costs ``samples`` full checks and a
    robot that mostly collides much less. Returns the rate (NaN for no samples) and, when
    every sample collides, the (at most five) pairs in collision most often over them.
    """
    if samples <= 0:
        return math.nan, []
    model, collision = robot._model, robot._collision_model
    data = model.createData()
    rng = np.random.default_rng(seed + 1)
    configurations = [robot.random_configuration(rng) for _ in range(samples)]
    hit = 0
    order = list(pairs)
    for q in configurations:
        pin.updateGeometryPlacements(model, data, collision, geom_data, q)
        for k, pair in enumerate(order):
            if pin.computeCollision(collision, geom_data, index[pair]):
                hit += 1
                order.insert(0, order.pop(k))  # the last colliding pair first (cheap when bad)
                break
    rate = hit / samples
    if hit < samples:
        return rate, []
    counts = np.zeros(len(pairs))
    for q in configurations:
        pin.updateGeometryPlacements(model, data, collision, geom_data, q)
        counts += [bool(pin.computeCollision(collision, geom_data, index[c])) for c in pairs]
    top = np.argsort(-counts, kind="stable")[:5]
    return rate, [pairs[int(k)] for k in top]


def _convexify(geometry_model: pin.GeometryModel) -> None:
    """Replace BVH mesh geometries by their convex hulls (qhull), in place.

    Not ``buildConvexRepresentation``: it takes the mesh's own triangles as the faces of the
    polytope, and on a mesh that is not convex in that triangulation coal's support function
    (hill climbing over the vertex graph) can stop at a vertex that is not the farthest, so
    GJK/EPA miss contacts (issue #22). A mesh whose hull coal cannot represent (a vertex with
    too many neighbours) keeps its mesh, with a :class:`ModelWarning` naming it.
    """
    for obj in geometry_model.geometryObjects:
        if hasattr(obj.geometry, "buildConvexHull"):
            geom = obj.geometry.clone()  # the loaded mesh is shared (_MESHES): not modified
            try:
                geom.buildConvexHull(True, "Qt")
            except RuntimeError as exc:
                reason = str(exc).strip().splitlines()[-1]
                warnings.warn(
                    f"collision geometry '{obj.name}' keeps its mesh: coal could not build "
                    f"its convex hull ({reason})",
                    ModelWarning,
                    stacklevel=4,
                )
                continue
            obj.geometry = geom.convex


_EDITABLE_MODEL_FIELDS = (
    "jointPlacements",
    "inertias",
    "armature",
    "damping",
    "friction",
    "rotorInertia",
    "rotorGearRatio",
    "gravity",
    "lowerPositionLimit",
    "upperPositionLimit",
    "velocityLimit",
    "effortLimit",
)
"""The ``pin.Model`` fields :meth:`Robot.edit_model` accepts edits of (with the frames')."""

_EDITABLE_GEOMETRY_FIELDS = (
    "placement",
    "geometry",
    "disableCollision",
    "meshScale",
    "meshColor",
    "meshPath",
    "meshMaterial",
    "meshTexturePath",
    "overrideMaterial",
)


def _copy_model_values(source: pin.Model, target: pin.Model) -> None:
    """Write the editable values of ``source`` into ``target`` (same structure assumed)."""
    for field in _EDITABLE_MODEL_FIELDS[2:]:
        setattr(target, field, getattr(source, field))
    if source.njoints == target.njoints:
        for i in range(target.njoints):
            target.jointPlacements[i] = source.jointPlacements[i]
            target.inertias[i] = source.inertias[i]
    if source.nframes == target.nframes:
        for i in range(target.nframes):
            frame, new = target.frames[i], source.frames[i]
            frame.placement = new.placement
            frame.inertia = new.inertia


def _copy_geometry_values(
    source: pin.GeometryModel, target: pin.GeometryModel, robot_geometries: int
) -> None:
    """Write ``source``'s collision pairs and robot geometries' editable values into ``target``.

    Same geometries assumed (checked by the caller).
    """
    for i in range(robot_geometries):
        obj, new = target.geometryObjects[i], source.geometryObjects[i]
        for field in _EDITABLE_GEOMETRY_FIELDS:
            if field != "geometry":
                setattr(obj, field, getattr(new, field))
        if not _same_shape(obj.geometry, new.geometry):
            obj.geometry = new.geometry.clone()  # the caller's shape stays the caller's
    target.removeAllCollisionPairs()
    for pair in source.collisionPairs:
        target.addCollisionPair(pin.CollisionPair(pair.first, pair.second))


_COSTLY_SHAPES = (
    coal.BVHModelBase,
    coal.ConvexBase,
    coal.HeightFieldOBBRSS,
    coal.HeightFieldAABB,
    coal.OcTree,
)
"""Shapes whose clone costs more than a comparison with coal's ``==`` (meshes).

Every coal shape can be modified in place from Python (``Box.halfSide[:]``, ``Sphere.radius``,
``BVHModel.vertices()[...]``, ``Convex.points()[...]``, ``HeightField.updateHeights``,
``OcTree.setOccupancyThres``, ``loadFromBinary`` on any shape...), and ``GeometryModel.copy()``
shares them: whatever the robot hands out holds clones instead (:func:`_clone_shapes`).
"""


def _same_shape(a: Any, b: Any) -> bool:
    """The same coal shape by content (coal's ``==``; shapes of other types differ)."""
    return type(a) is type(b) and bool(a == b)


def _clone_shapes(
    geometry_model: pin.GeometryModel, kept: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Give every geometry object of ``geometry_model`` a clone of its shape, in place.

    With ``kept`` (the clones of :data:`_COSTLY_SHAPES` returned by the previous call, by
    geometry name), a kept clone that still equals the shape by content is used again
    instead of a new clone. Returns the clones of costly shapes now in ``geometry_model``.
    """
    clones: dict[str, Any] = {}
    for obj in geometry_model.geometryObjects:
        shape = obj.geometry
        if kept is not None and isinstance(shape, _COSTLY_SHAPES):
            clone = kept.get(obj.name)
            if clone is None or not _same_shape(clone, shape):
                clone = shape.clone()
            clones[obj.name] = clone
        else:
            clone = shape.clone()
        obj.geometry = clone
    return clones


def configuration_from_joint_values(robot: Robot, values: dict[str, float]) -> FloatArray:
    """Default posture with the named 1-DoF joints set to ``values`` [rad or m]."""
    q = robot.q_default.copy()
    for name, value in values.items():
        jid = robot.joint_id(name)
        joint = robot._model.joints[jid]
        if joint.nq != 1:
            raise ShapeError(f"joint '{name}' value", (joint.nq,), (1,))
        q[joint.idx_q] = float(value)
    return q
