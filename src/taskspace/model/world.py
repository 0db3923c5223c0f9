"""Obstacle world: primitive and mesh obstacles with poses, as coal collision geometries.

Obstacles are immutable values (a frozen dataclass: "moving" one means removing it and adding
a new one) and a :class:`World` carries a :attr:`~World.version` that changes at every
mutation. Objects derived from a world (collision checkers, configuration spaces, compiled
checkers, the collision data of a state) record the version they were built from and rebuild
when it changed: they are invalidated by construction, not by comparing counts (clearing the
world and adding the same number of obstacles keeps the counts and changes the version).

Thread safety: :class:`Obstacle` is an immutable value (do not modify its placement or geometry in
place); a :class:`World` is not locked (see there).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from taskspace._validation import as_float_array, as_vector, check_positive
from taskspace.errors import InvalidInputError, ModelLoadError, UnknownNameError


def as_se3(pose: Any, name: str = "pose") -> pin.SE3:
    """Convert a pose to ``pin.SE3``.

    Args:
        pose: a ``pin.SE3``, a 4x4 homogeneous matrix, a position ``[x, y, z]`` [m], or a
            position + quaternion ``[x, y, z, qx, qy, qz, qw]``.
        name: argument name used in error messages.
    """
    if isinstance(pose, pin.SE3):
        # a pin.SE3 holds any 3x3 block and NaN: checked as a 4x4 matrix is (a scaled or
        # NaN "rotation" gave a log6 of a non-rotation, reported as a solved step)
        _check_homogeneous(pose.homogeneous, name)
        return pose.copy()
    arr = as_float_array(pose, name)  # refuses None, text, complex values, ragged nesting
    if arr.shape == (4, 4):
        _check_homogeneous(arr, name)
        return pin.SE3(arr[:3, :3], arr[:3, 3])
    if arr.shape == (3,):
        return pin.SE3(np.eye(3), as_vector(arr, 3, name))
    if arr.shape == (7,):
        vec = as_vector(arr, 7, name)
        quat = vec[3:]
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > 1e-6:
            raise InvalidInputError(
                f"{name} quaternion (x, y, z, w) must have unit norm, got {norm}"
            )
        return pin.XYZQUATToSE3(vec)
    raise InvalidInputError(
        f"{name} must be a pin.SE3, a 4x4 matrix, [x, y, z] or [x, y, z, qx, qy, qz, qw]; "
        f"got an array of shape {arr.shape}"
    )


def _check_homogeneous(arr: np.ndarray, name: str) -> None:
    if not np.isfinite(arr[:3]).all():
        raise InvalidInputError(f"{name} has non-finite entries")
    rot = arr[:3, :3]
    if np.abs(rot.T @ rot - _EYE3).max() > 1e-6 or np.linalg.det(rot) < 0:
        raise InvalidInputError(f"{name} rotation block is not a rotation matrix")


_EYE3 = np.eye(3)


@dataclass(frozen=True)
class Obstacle:
    """A rigid obstacle fixed in the world (an immutable value).

    Its fields cannot be reassigned: to move an obstacle, remove it and add a new one
    (``robot.clear_obstacles()`` / ``robot.add_obstacle(...)``), which changes the world's
    :attr:`World.version`. :meth:`Robot.add_obstacle <taskspace.model.Robot.add_obstacle>`
    puts a clone of ``geometry`` (and a copy of ``placement``) into the robot's collision
    model, so modifying them in place afterwards does not change the robot's collision
    answers; it changes this object only (and what it is later passed to), so do not.

    Attributes:
        name: unique name.
        geometry: coal collision geometry (in its own frame).
        placement: pose of the geometry frame in the world.
        color: RGBA color in [0, 1] for viewers.
        mesh_path: source file for mesh obstacles (viewers load it), else ``None``.
    """

    name: str
    geometry: coal.CollisionGeometry
    placement: pin.SE3
    color: np.ndarray = field(default_factory=lambda: np.array([0.6, 0.6, 0.65, 1.0]))
    mesh_path: str | None = None

    @staticmethod
    def box(name: str, size: Sequence[float], pose: Any = (0.0, 0.0, 0.0), **kw: Any) -> Obstacle:
        """Box of full side lengths ``size`` [m] centered at ``pose``."""
        s = as_vector(size, 3, "size")
        for i in range(3):
            check_positive(s[i], f"size[{i}]")
        return Obstacle(name, coal.Box(*s), as_se3(pose), **kw)

    @staticmethod
    def sphere(name: str, radius: float, pose: Any = (0.0, 0.0, 0.0), **kw: Any) -> Obstacle:
        """Sphere of ``radius`` [m] centered at ``pose``."""
        return Obstacle(name, coal.Sphere(check_positive(radius, "radius")), as_se3(pose), **kw)

    @staticmethod
    def cylinder(
        name: str, radius: float, length: float, pose: Any = (0.0, 0.0, 0.0), **kw: Any
    ) -> Obstacle:
        """Cylinder of ``radius`` and ``length`` [m] along its z axis, centered at ``pose``."""
        geom = coal.Cylinder(check_positive(radius, "radius"), check_positive(length, "length"))
        return Obstacle(name, geom, as_se3(pose), **kw)

    @staticmethod
    def mesh(
        name: str, path: str | Path, pose: Any = (0.0, 0.0, 0.0), scale: float = 1.0, **kw: Any
    ) -> Obstacle:
        """Triangle mesh read from ``path`` (STL, OBJ, DAE...), scaled by ``scale``."""
        p = Path(path)
        if not p.is_file():
            raise ModelLoadError(f"mesh file not found: {p}")
        loader = coal.MeshLoader()
        try:
            geom = loader.load(str(p), np.full(3, float(scale)))
        except Exception as exc:  # coal raises a generic RuntimeError
            raise ModelLoadError(f"cannot load mesh {p}: {exc}") from exc
        return Obstacle(name, geom, as_se3(pose), mesh_path=str(p), **kw)


_VERSIONS = itertools.count(1)
"""Source of world versions, shared by every world (a version is never reused)."""


class World:
    """A named collection of obstacles with a version that changes at every mutation.

    :attr:`version` is drawn from one process-wide increasing counter, so it never takes the
    same value twice, also across worlds: an object that recorded ``world.version`` is stale
    exactly when the version differs. Mutations: :meth:`add`, :meth:`remove`, :meth:`clear`
    and :meth:`mark_changed` (called by the robot when it changes its collision pairs).

    Thread safety: a world is not locked; do not mutate it while another thread plans or
    checks collisions against it.
    """

    def __init__(self, obstacles: Sequence[Obstacle] = ()) -> None:
        self._obstacles: dict[str, Obstacle] = {}
        self._version = next(_VERSIONS)
        # the robot whose collision model holds these obstacles (robot.world), if any
        self._owner: Any = None
        for obstacle in obstacles:
            self._add(obstacle)

    @property
    def version(self) -> int:
        """Identifier of the current content; changes at every mutation, never reused."""
        return self._version

    def mark_changed(self) -> None:
        """Give the world a new :attr:`version` (e.g. after the collision pairs changed)."""
        self._version = next(_VERSIONS)

    def add(self, obstacle: Obstacle) -> None:
        """Add an obstacle; its name must be new.

        On a robot's world (``robot.world``) this is ``robot.add_obstacle(obstacle)``: the
        robot's collision model gets it too.
        """
        if self._owner is not None:
            self._owner.add_obstacle(obstacle)
            return
        self._add(obstacle)

    def _add(self, obstacle: Obstacle) -> None:
        if not isinstance(obstacle, Obstacle):
            raise InvalidInputError(
                f"expected an Obstacle (Obstacle.box, .sphere, .cylinder, .mesh), got "
                f"{type(obstacle).__name__}"
            )
        if obstacle.name in self._obstacles:
            raise InvalidInputError(
                f"an obstacle named '{obstacle.name}' already exists; remove it first or "
                "choose another name"
            )
        self._obstacles[obstacle.name] = obstacle
        self._version = next(_VERSIONS)

    def remove(self, name: str) -> Obstacle:
        """Remove and return the obstacle called ``name`` (on a robot's world: through it)."""
        if self._owner is not None:
            return self._owner.remove_obstacle(name)  # type: ignore[no-any-return]
        return self._remove(name)

    def _remove(self, name: str) -> Obstacle:
        if name not in self._obstacles:
            raise UnknownNameError("obstacle", name, self._obstacles)
        obstacle = self._obstacles.pop(name)
        self._version = next(_VERSIONS)
        return obstacle

    def clear(self) -> None:
        """Remove every obstacle (on a robot's world: through it)."""
        if self._owner is not None:
            self._owner.clear_obstacles()
            return
        self._obstacles.clear()
        self._version = next(_VERSIONS)

    def __getitem__(self, name: str) -> Obstacle:
        if name not in self._obstacles:
            raise UnknownNameError("obstacle", name, self._obstacles)
        return self._obstacles[name]

    def __iter__(self) -> Iterator[Obstacle]:
        return iter(self._obstacles.values())

    def __len__(self) -> int:
        return len(self._obstacles)

    @property
    def names(self) -> list[str]:
        """Obstacle names in insertion order."""
        return list(self._obstacles)
