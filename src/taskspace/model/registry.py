"""The robots ``Robot.load`` knows: our registry plus every robot of example-robot-data.

Our registry (``taskspace/robots_data/registry.yaml``, shipped inside the package and read
through :mod:`importlib.resources`) adds metadata (end effectors, locked joints, default
posture, description) to some robots and defines a few of our own (planar arms, pendulum,
cart-pole). Every other robot that example-robot-data provides (``ROBOTS`` of
``example_robot_data.robots_loader``) is available under its example-robot-data name with the
loader's own free flyer, SRDF and reference posture.

Thread safety: :class:`RobotSpec` is an immutable value (do not modify its ``default_posture``
dictionary in place); the look-up functions only read the registry (cached once per process) and
may run from several threads.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from taskspace._validation import YamlLines, read_yaml
from taskspace.errors import ModelLoadError, UnknownNameError

logger = logging.getLogger(__name__)

DATA_PACKAGE = "taskspace"
DATA_DIRECTORY = "robots_data"
"""Directory of the package holding ``registry.yaml`` and our URDFs (``urdf/``)."""

CACHE_ENVIRONMENT_VARIABLE = "TASKSPACE_CACHE_DIR"
"""Directory of the robot-summary cache (default ``$XDG_CACHE_HOME/taskspace`` or
``~/.cache/taskspace``)."""


@dataclass(frozen=True, kw_only=True)
class RobotSpec:
    """How to load one robot (see the comments at the top of ``registry.yaml``).

    Attributes:
        name: name given to :meth:`Robot.load`.
        source: ``"example-robot-data"`` or ``"urdf"`` (a URDF of ``robots_data``).
        description: one line shown by ``taskspace robots``.
        erd_name: example-robot-data loader name (source ``example-robot-data``).
        urdf: URDF path (source ``urdf``).
        free_flyer: the robot has a floating base.
        end_effectors: end-effector frame names.
        locked_joints: joints removed from the model, held at their default value.
        default_posture: ``{"srdf": NAME}`` (SRDF reference configuration), ``{"joints":
            {name: value}}`` and/or ``{"base": [x, y, z]}``; empty for the neutral posture.
        passive_joints: unactuated joints (effort limit 0).
        in_registry: the entry comes from our registry (False: example-robot-data only).
    """

    name: str
    source: str
    description: str = ""
    erd_name: str | None = None
    urdf: Path | None = None
    free_flyer: bool = False
    end_effectors: tuple[str, ...] = ()
    locked_joints: tuple[str, ...] = ()
    default_posture: dict[str, Any] = field(default_factory=dict)
    passive_joints: tuple[str, ...] = ()
    in_registry: bool = True


def data_directory() -> Path:
    """Directory of the package data (``registry.yaml``, ``urdf/``) as a file-system path.

    Raises:
        ModelLoadError: the package data is missing or not on the file system (zip import).
    """
    root = resources.files(DATA_PACKAGE) / DATA_DIRECTORY
    if not isinstance(root, Path) or not (root / "registry.yaml").is_file():
        raise ModelLoadError(
            f"robot registry not found in the taskspace package ({root}/registry.yaml); "
            "reinstall taskspace (pip install taskspace) from a wheel or source tree that "
            "includes its package data"
        )
    return root


_ENTRY_KEYS = (
    "source",
    "name",
    "urdf",
    "description",
    "free_flyer",
    "end_effectors",
    "locked_joints",
    "passive_joints",
    "default_posture",
)
_POSTURE_KEYS = ("srdf", "srdf_optional", "joints", "base")


def _registry_entries(
    raw: Any, source_file: Path, lines: YamlLines | None = None
) -> dict[str, RobotSpec]:
    """Check and convert the entries of a registry file (errors give ``file:line``)."""
    lines = lines or YamlLines(source_file, None)
    if not isinstance(raw, dict):
        raise ModelLoadError(
            f"{lines.where()}: the registry must be a mapping of robot names to entries, "
            f"got {type(raw).__name__}"
        )
    specs: dict[str, RobotSpec] = {}
    root = source_file.parent
    for name, entry in raw.items():
        where = lines.where(name)
        if not isinstance(entry, dict):
            raise ModelLoadError(f"{where}: entry '{name}' must be a mapping")

        def fail(key: str, message: str, name: Any = name) -> ModelLoadError:
            return ModelLoadError(f"{lines.where(name, key)}: entry '{name}': {message}")

        unknown = [k for k in entry if k not in _ENTRY_KEYS]
        if unknown:
            raise fail(
                str(unknown[0]),
                f"unknown key {unknown[0]!r}; valid keys are: {', '.join(_ENTRY_KEYS)}",
            )
        source = entry.get("source")
        if source not in ("example-robot-data", "urdf"):
            raise fail(
                "source",
                f"unknown source {source!r}; valid sources are: example-robot-data, urdf",
            )
        required = "name" if source == "example-robot-data" else "urdf"
        if not isinstance(entry.get(required), str) or not entry[required]:
            raise fail(
                required,
                f"source {source} needs '{required}' (a string), got {entry.get(required)!r}",
            )
        for key in ("description", "name", "urdf"):
            if key in entry and not isinstance(entry[key], str):
                raise fail(key, f"'{key}' must be a string, got {entry[key]!r}")
        if not isinstance(entry.get("free_flyer", False), bool):
            raise fail(
                "free_flyer", f"free_flyer must be true or false, got {entry['free_flyer']!r}"
            )
        names: dict[str, tuple[str, ...]] = {}
        for key in ("end_effectors", "locked_joints", "passive_joints"):
            value = entry.get(key, [])
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise fail(key, f"'{key}' must be a list of names, got {value!r}")
            names[key] = tuple(value)
        posture = entry.get("default_posture") or {}
        if not isinstance(posture, dict):
            raise fail("default_posture", f"default_posture must be a mapping, got {posture!r}")
        unknown = [k for k in posture if k not in _POSTURE_KEYS]
        if unknown:
            raise fail(
                "default_posture",
                f"default_posture: unknown key {unknown[0]!r}; valid keys are: "
                f"{', '.join(_POSTURE_KEYS)}",
            )
        joints = posture.get("joints", {}) or {}
        if not isinstance(joints, dict) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in joints.values()
        ):
            raise fail(
                "default_posture",
                f"default_posture.joints must map joint names to numbers, got {joints!r}",
            )
        base = posture.get("base")
        if base is not None and not (
            isinstance(base, list)
            and len(base) == 3
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in base)
        ):
            raise fail("default_posture", f"default_posture.base must be [x, y, z], got {base!r}")
        specs[str(name)] = RobotSpec(
            name=str(name),
            source=source,
            description=entry.get("description", ""),
            erd_name=entry.get("name"),
            urdf=(root / entry["urdf"]) if "urdf" in entry else None,
            free_flyer=entry.get("free_flyer", False),
            end_effectors=names["end_effectors"],
            locked_joints=names["locked_joints"],
            default_posture=dict(posture),
            passive_joints=names["passive_joints"],
        )
    return specs


def read_registry(path: str | Path) -> dict[str, RobotSpec]:
    """Entries of a registry file (the format of ``registry.yaml``) by name.

    Raises:
        ModelLoadError: missing file, malformed YAML or a malformed entry; the message gives
            ``file:line`` and the valid keys or values.
    """
    raw, lines = read_yaml(path, "robot registry")
    return _registry_entries(raw, Path(path), lines)


@lru_cache(maxsize=1)
def registry() -> dict[str, RobotSpec]:
    """Entries of our registry (``registry.yaml``) by name."""
    return read_registry(data_directory() / "registry.yaml")


@lru_cache(maxsize=1)
def example_robot_data_loaders() -> dict[str, Any]:
    """Loader classes of example-robot-data by name (its ``ROBOTS`` dictionary).

    Raises:
        ModelLoadError: example-robot-data is not installed.
    """
    try:
        from example_robot_data.robots_loader import ROBOTS
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise ModelLoadError(
            "example_robot_data is not installed: pip install example-robot-data-loaders"
        ) from exc
    return dict(ROBOTS)


def _erd_spec(name: str, loader: Any) -> RobotSpec:
    posture: dict[str, Any] = {}
    if getattr(loader, "srdf_filename", "") and getattr(loader, "ref_posture", None):
        posture = {"srdf": loader.ref_posture, "srdf_optional": True}
    return RobotSpec(
        name=name,
        source="example-robot-data",
        description=f"example-robot-data '{name}'",
        erd_name=name,
        free_flyer=bool(getattr(loader, "free_flyer", False)),
        default_posture=posture,
        in_registry=False,
    )


@lru_cache(maxsize=1)
def available_robots() -> dict[str, RobotSpec]:
    """Every robot :meth:`Robot.load` accepts: our registry first, then example-robot-data.

    A registry entry shadows the example-robot-data robot of the same name (it adds our
    metadata); the other example-robot-data robots keep the loader's free flyer, SRDF and
    reference posture.
    """
    specs = dict(registry())
    for name, loader in example_robot_data_loaders().items():
        if name not in specs:
            specs[name] = _erd_spec(name, loader)
    return specs


def robot_spec(name: str) -> RobotSpec:
    """How to load the robot called ``name``; the error lists the valid names."""
    if not isinstance(name, str):
        raise UnknownNameError("robot", repr(name), available_robots())
    specs = available_robots()
    if name not in specs:
        raise UnknownNameError("robot", name, specs)
    return specs[name]


# ---------------------------------------------------------------------- summaries (CLI)
def cache_directory() -> Path:
    """The cache directory of taskspace (robot listing, sphere models).

    ``$TASKSPACE_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/taskspace`` (default
    ``~/.cache/taskspace``).
    """
    env = os.environ.get(CACHE_ENVIRONMENT_VARIABLE)
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "taskspace"


def _cache_key() -> str:
    from importlib.metadata import PackageNotFoundError, version

    parts = []
    for dist in ("example-robot-data", "example-robot-data-loaders", "pin"):
        try:
            parts.append(f"{dist}={version(dist)}")
        except PackageNotFoundError:
            parts.append(f"{dist}=?")
    parts.append((data_directory() / "registry.yaml").read_text())
    return hashlib.sha1("\n".join(parts).encode()).hexdigest()[:16]


def _kinematic_size(spec: RobotSpec) -> tuple[int, int]:
    """(nq, nv) of the model ``Robot.load`` builds, from the kinematic tree only."""
    import warnings

    import pinocchio as pin

    if spec.source == "urdf":
        if spec.urdf is None:
            raise ModelLoadError(f"registry entry '{spec.name}' has no urdf path")
        path, free_flyer = str(spec.urdf), spec.free_flyer
    else:
        from example_robot_data.utils import RobotLoader

        loader = example_robot_data_loaders()[str(spec.erd_name)]
        if getattr(loader, "sdf_filename", "") and not hasattr(pin, "buildModelFromSdf"):
            raise ModelLoadError("SDF description; this Pinocchio is built without SDF support")
        if loader.__init__ is not RobotLoader.__init__ or not loader.urdf_filename:
            inst = loader()  # custom loaders (SDF, reduced models): the loader's own model
            model = inst.robot._model
            return _reduced_size(model, spec)
        from example_robot_data.robots_loader import getModelPath

        rel = os.path.join(loader.path, loader.urdf_subpath, loader.urdf_filename)
        path = os.path.join(loader.model_path or getModelPath(rel), rel)
        free_flyer = spec.free_flyer
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if free_flyer:
            model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
        else:
            model = pin.buildModelFromUrdf(path)
    return _reduced_size(model, spec)


def _reduced_size(model: Any, spec: RobotSpec) -> tuple[int, int]:
    nq, nv = int(model.nq), int(model.nv)
    for jname in spec.locked_joints:
        if model.existJointName(jname):
            joint = model.joints[model.getJointId(jname)]
            nq -= int(joint.nq)
            nv -= int(joint.nv)
    return nq, nv


def robot_summaries(
    progress: Callable[[list[str]], Iterable[str]] | None = None,
) -> dict[str, dict[str, Any]]:
    """``{name: {"nq", "nv", "floating", "source", "end_effectors", "description"}}``.

    Covers every name of :func:`available_robots`. Sizes come from the kinematic trees only
    (no meshes); the whole listing is cached on disk in :data:`CACHE_ENVIRONMENT_VARIABLE`
    (or the user cache directory), keyed by the versions of example-robot-data and
    Pinocchio and the registry's content, so a warm listing imports neither. ``nq``/``nv``
    are ``None`` for a robot whose description cannot be read (its ``error`` says why).

    Args:
        progress: wraps the list of names read when the cache is cold (e.g. a progress bar).
    """
    key = _cache_key()
    cache_file = cache_directory() / f"robots-{key}.json"
    try:
        cached = json.loads(cache_file.read_text())
        if isinstance(cached, dict) and cached.get("key") == key:
            return dict(cached["robots"])
    except (OSError, ValueError, KeyError):
        pass
    out: dict[str, dict[str, Any]] = {}
    specs = available_robots()
    names = list(specs)
    for name in progress(names) if progress is not None else names:
        spec = specs[name]
        entry: dict[str, Any]
        try:
            nq, nv = _kinematic_size(spec)
            entry = {"nq": nq, "nv": nv}
        except Exception as exc:  # any failure of a third-party description: reported
            entry = {"nq": None, "nv": None, "error": f"{type(exc).__name__}: {exc}"}
        out[name] = {
            **entry,
            "floating": spec.free_flyer,
            "source": "registry" if spec.in_registry else "example-robot-data",
            "end_effectors": list(spec.end_effectors),
            "description": spec.description,
        }
    try:
        cache_file.parent.mkdir(parents=True, exist_ok=True)
        tmp = cache_file.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"key": key, "robots": out}))
        tmp.replace(cache_file)
    except OSError as exc:
        logger.info("cannot write the robot cache %s: %s", cache_file, exc)
    return out
