"""Configuration validity ``q in Q_free`` for a robot and its obstacle world (slides 3:28-3:32).

A configuration is *free* when no checked collision pair of ``robot.collision_model`` is in
contact: robot-robot pairs (those left after the SRDF's disabled pairs are removed) and
robot-obstacle pairs. The test is exact for the geometry held by the robot's collision model:
triangle meshes (``Robot.load(name)``) or their convex hulls
(``Robot.load(name, convex_collision=True)``); :attr:`CollisionChecker.geometry` says which.
No inflation or sphere approximation is used, so "free" means free for that geometry.

Speed (Panda, MotionBenchMaker scenes, 156-236 pairs, measured on a 2-core machine): Pinocchio's
plain ``computeCollisions`` stopping at the first hit costs about 58 us per configuration (it runs
the narrow phase on every pair); the broad phase (a dynamic AABB tree over all geometries,
``pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager``: only pairs whose bounding boxes
overlap reach the narrow phase) brings this to about 12.7 us for one configuration per call
(14.7 us through :meth:`CollisionChecker.is_valid`) and 8-10 us per configuration for a batch
evaluated in one C++ call (``pin.computeCollisionsInParallel``, one thread, stopping at the
first collision of the batch when asked). Pinocchio's *tree* variant of the pool
(``pin.TreeBroadPhaseManagerPool_DynamicAABBTreeCollisionManager``: one AABB tree per joint
subtree) gives the same answers 10-20 % faster and is the one used: 7.7-10.5 us per
configuration over the seven scenarios on random configurations (plain pool 8.6-12.8 us,
same run, idle machine, 2026-11-22). About 5.8 us of it is fixed per configuration (it is the
cost with a single collision pair: kinematics, placements, tree updates); the rest is the
narrow phase of the pairs whose boxes overlap. Planners therefore send whole edges (or
several edges) per call, see :mod:`taskspace.planning.rrt_connect`.

Compiled checker (``CollisionCheckerOptions.native``, default when
``taskspace/_native/planning_kernel.cpp`` is built): the queries go to a C++ checker on
copies of the models with the same pairs, boxes and exact narrow phase (Pinocchio's placements,
coal's ``computeAABB``, Pinocchio's ``computeCollision``), a broad phase over the pair list
grouped by moving object with coal's oriented-box test before the narrow phase, the last
colliding pair tested first; about 1.1-1.3 us per random configuration and 1.35 us per check
inside the compiled RRT-Connect (planner included), see the kernel's header. Answers agree
with the pool up to configurations that graze an obstacle by less than a millimetre (coal's
GJK warm start depends on the history of calls).

Tried and not used in the pool path: (1) testing the last colliding pair first (the compiled
checker does it; it gains about 2 % there): the batched broad-phase call does not report which
pair collided, so the cache cannot be maintained from Python; (2) per-link bounding spheres
against obstacle boxes as a Python prefilter: it needs the forward kinematics per
configuration in Python and can only certify "free", which the broad phase already does in C++
for every pair whose boxes are disjoint.

Thread safety: :class:`CollisionChecker` is one per thread (see there);
:class:`CollisionCheckerOptions` is immutable. A :class:`FunctionChecker` answers with its function
(safe to share when the function is), but its ``checks`` counter is not locked (calls from several
threads may lose counts): one per thread when the counts matter.
"""

from __future__ import annotations

import logging
import weakref
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import as_matrix
from taskspace.errors import PlanningError
from taskspace.model.collision_requests import without_cached_guess
from taskspace.model.robot import Robot

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

NATIVE_PAIR_CACHE = 1
"""Colliding pairs remembered by the compiled checker and tested first (0 disables it)."""

_EXACT_PAIR_SAMPLES = 16
"""Random configurations on which :attr:`CollisionChecker.sphere_exact_pairs` are found."""

KERNEL_CHUNK = 4096
"""Rows per call of the compiled checker in a batch: it holds the GIL during a call, so a
large batch is split to let other threads run and Ctrl-C interrupt it between calls."""


class ValidityChecker(Protocol):
    """What planners need to decide ``q in Q_free`` (implemented by :class:`CollisionChecker`).

    Attributes:
        checks: number of configurations evaluated so far.
    """

    checks: int

    def first_invalid(self, configurations: FloatArray) -> int:
        """Index of the first invalid row of ``configurations`` (shape (n, d)), or -1.

        Rows are evaluated in order and evaluation stops at the first invalid one.
        """
        ...

    def are_valid(self, configurations: FloatArray) -> BoolArray:
        """Validity of every row of ``configurations`` (shape (n, d))."""
        ...

    def explain(self, q: FloatArray) -> str:
        """Human-readable reason why ``q`` is invalid (for error messages)."""
        ...


@dataclass(frozen=True, kw_only=True)
class CollisionCheckerOptions:
    """Settings of :class:`CollisionChecker`.

    Attributes:
        broadphase: use the dynamic AABB tree broad phase, one tree per joint subtree
            (exact, only skips pairs whose axis-aligned bounding boxes are disjoint);
            ``False`` runs the narrow phase on every pair (Pinocchio's ``computeCollisions``).
        native: answer the queries with the compiled checker
            (``taskspace/_native/planning_kernel.cpp``, same broad phase structure and exact
            narrow phase) when it is built and ``broadphase`` is on; otherwise Pinocchio's
            ``computeCollisionsInParallel`` on a broad-phase pool.
    """

    broadphase: bool = True
    native: bool = True


_SPHERE_CACHE: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()
"""Sphere models per robot (:meth:`CollisionChecker.sphere_model`): (collision model, key,
model); the checkers of one robot (one per configuration space) share them."""

_SAMPLES_CACHE: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()
"""Per robot: (model, the random configurations of :attr:`CollisionChecker.sphere_exact_pairs`)."""


def _same_key(a: tuple[Any, ...], b: tuple[Any, ...]) -> bool:
    return len(a) == len(b) and all(
        x[:3] == y[:3] and x[3].isApprox(y[3], 0.0) for x, y in zip(a, b)
    )


class CollisionChecker:
    """Exact self- and world-collision test of a :class:`~taskspace.model.Robot`.

    The checker keeps its own copies of the robot's models (a broad-phase pool, the compiled
    checker; each built at the first query that uses it) and records the
    :attr:`~taskspace.model.World.version` of the robot's world it was built from; every
    query compares it with the current version (one integer comparison) and drops the
    copies when the world changed (obstacles added, removed, cleared, or the robot's
    collision pairs changed through its methods), so it always answers for the current
    world. :meth:`update_world` forces a rebuild. The checker keeps
    its own Pinocchio data, so using it does not touch ``robot.data``.

    Thread safety: a checker is not thread-safe (its Pinocchio data, pool and compiled
    checker are workspaces); give each thread its own checker. The world must not be changed
    while a query runs.

    Args:
        robot: the robot with its obstacle world.
        options: checker settings.

    Attributes:
        checks: number of configurations evaluated (incremented by every query).
    """

    def __init__(self, robot: Robot, options: CollisionCheckerOptions | None = None) -> None:
        self.robot = robot
        self.options = options or CollisionCheckerOptions()
        self.checks = 0
        self._nq = robot.nq
        self._pool: Any = None
        self._geometry_pool: Any = None
        self._model: Any = None
        self._data: Any = None
        self._geom_data: Any = None
        self._kernel: Any = None
        self._kernel_checked = False
        self._sphere_kernel: Any = None  # the kernel whose spheres are set (sphere_kernel)
        self._world: Any = None
        self._world_version = -1
        self._geometry_model: Any = None
        self.update_world()

    # ------------------------------------------------------------------ set-up
    def update_world(self) -> None:
        """Follow ``robot.collision_model``: drop the copies made for the previous world.

        Each copy is built again from the current models at the first query that needs it
        (the compiled checker by :meth:`native_kernel`, Pinocchio's pool and data for the
        Python-side queries by ``_no_cached_guess``), so that a scene change pays only for
        what the next queries use.
        """
        robot = self.robot
        geom = robot._collision_model
        self._pool = None
        self._geometry_pool = None
        self._data = None
        self._geom_data = None
        self._guess_off = False  # the Python-side structures are not built yet
        self._model = robot._model
        self._ngeoms = geom.ngeoms
        self._kernel = None
        self._kernel_checked = False
        self._sphere_exact_pairs: tuple[tuple[str, str], ...] = ()
        self._sphere_kernel = None  # (not kept alive past its world)
        self._world = robot.world
        self._world_version = robot.world.version
        self._geometry_model = geom

    def _no_cached_guess(self) -> None:
        """Build the data of the Python-side queries, cached GJK guess off (once a world).

        The broad-phase pool (or the plain geometry pool without ``broadphase``), the model's
        and the geometry model's data on the robot's current models. Pinocchio's default
        requests start each pair's narrow phase from its previous call, which can report a
        real penetration free (see ``taskspace.model.collision_requests``): turned off in
        every geometry data. Done at the first query that uses the pools or ``_geom_data``
        rather than in :meth:`update_world`: the compiled checker, used by default, works on
        its own copies, and a scene change would pay for structures no query uses.
        """
        model, geom = self._model, self._geometry_model
        if self.options.broadphase:
            pool = pin.TreeBroadPhaseManagerPool_DynamicAABBTreeCollisionManager(model, geom, 1)
            self._pool = pool
        else:
            pool = self._geometry_pool = pin.GeometryPool(model, geom, 1)
        self._data = model.createData()
        self._geom_data = geom.createData()
        for geometry_data in [*pool.getGeometryDatas(), self._geom_data]:
            without_cached_guess(geometry_data)
        self._guess_off = True

    def _query_kernel(self) -> Any:
        """The compiled checker if the queries use it (``options.native``), else ``None``."""
        if not self.options.native or (self._kernel_checked and self._kernel is None):
            return None
        if self._kernel is not None:
            return self._kernel
        return self.native_kernel()

    def native_kernel(self) -> Any:
        """The compiled checker on copies of the robot's models, or ``None`` (not built).

        It is ``taskspace._native.planning_kernel().CollisionKernel`` (used by the compiled
        RRT-Connect; ``None`` for robots whose configuration is not a plain vector,
        ``nq != nv``: those use Pinocchio's broad-phase pool). The handle answers for the
        world as it was at this call: after any
        change of the world, call this method again (it then returns a new handle built on
        the current world; the compiled planner does so at every plan). ``None`` when the
        kernel is not built or the broad phase is disabled in the options.
        """
        self._sync()
        kernel = self._kernel
        if kernel is not None:  # built for this world (nq == nv: a robot keeps its model)
            return kernel
        if self.robot.nq != self.robot.nv:  # the compiled checker takes plain vectors only
            self._kernel_checked = True
            return None
        if self._kernel is None and self.options.broadphase:
            from taskspace._native import planning_kernel

            self._kernel_checked = True
            module = planning_kernel()
            if module is None:
                return None
            model = self.robot._model.copy()
            geom = self.robot._collision_model.copy()
            # geometry data None: the kernel makes the parts of a GeometryData it uses (without
            # the distance and contact-patch functors of geom.createData(), 2/3 of its cost)
            self._kernel = module.CollisionKernel(
                model, model.createData(), geom, None, NATIVE_PAIR_CACHE
            )
        return self._kernel

    def sphere_model(self) -> Any:
        """The conservative spheres of the robot's moving geometry objects (cached).

        :func:`~taskspace.planning.sphere_model.sphere_model` with its default options on
        every geometry object attached to a moving joint (built once per collision model;
        obstacles added later do not change it). Fitting and proving the spheres of a robot
        takes seconds; each geometry's result is kept in the on-disk cache
        (:func:`~taskspace.planning.sphere_model.sphere_cache_directory`, keyed by the
        geometry's content), so later processes load it.

        Raises:
            InvalidInputError: a moving geometry of a shape the sphere model does not handle.
        """
        from taskspace.planning.sphere_model import sphere_model

        geom = self.robot._collision_model
        objs = geom.geometryObjects
        # what the spheres depend on: the moving objects, their geometry and placement. Only
        # the robot's geometries can move (obstacles are on the universe, joint 0, and follow
        # them); each object read once (each Python access to one is a Boost call). The
        # placement is copied: `obj.placement` refers to the object's own SE3 inside the
        # model's vector, which a key must not alias (an in-place change would compare equal,
        # and adding an obstacle may move the vector and leave it dangling)
        key_list = []
        for i in range(self.robot._robot_geometry_count):
            obj = objs[i]
            joint = obj.parentJoint
            if joint != 0:
                key_list.append((i, obj.name, joint, pin.SE3(obj.placement)))
        key = tuple(key_list)
        moving = [k[0] for k in key]
        edits = self.robot._geometry_edits  # shapes replaced by Robot.edit_collision_model
        cached = _SPHERE_CACHE.get(self.robot)
        if (
            cached is None
            or cached[0] is not geom
            or cached[3] != edits
            or not _same_key(cached[1], key)
        ):
            cached = (geom, key, sphere_model(geom, moving), edits)
            _SPHERE_CACHE[self.robot] = cached
        return cached[2]

    def sphere_kernel(self) -> Any:
        """:meth:`native_kernel` with the robot's spheres (:meth:`sphere_model`) set.

        The kernel then also answers with its sphere checkers (``collisions_with(rows,
        checker)``: 0 exact, 1 spheres then the exact narrow phase where they touch, 2 spheres
        only; ``first_invalid_on_edge``), see ``taskspace/_native/planning_kernel.cpp``.
        ``None`` when the compiled checker is not available.
        """
        kernel = self.native_kernel()
        if kernel is not None and kernel is not self._sphere_kernel:
            if not kernel.has_spheres:  # (a kernel's spheres can be replaced, not removed)
                spheres = self.sphere_model()
                kernel.set_spheres(
                    spheres.centers,
                    spheres.radii,
                    spheres.joints.astype(np.int32),
                    spheres.geometries.astype(np.int32),
                    spheres.certified_margin,
                )
                self._mark_exact_pairs(kernel)
            self._sphere_kernel = kernel
        return kernel

    def sphere_kernel_ready(self) -> Any:
        """:meth:`sphere_kernel`, built unless it was for the current world (a cheap check).

        Planners call it before their clock starts (the sphere model's fit is set-up) and
        use the kernel it returns (``None``: the compiled checker is not available).
        """
        self._sync()
        kernel = self._sphere_kernel  # (reset with the kernel when the world changes)
        if kernel is None:
            kernel = self.sphere_kernel()
        return kernel

    def _mark_exact_pairs(self, kernel: Any) -> None:
        """Mark the kernel's self pairs of :attr:`sphere_exact_pairs` (after set_spheres)."""
        robot = self.robot
        cached = _SAMPLES_CACHE.get(robot)
        if cached is None or cached[0] is not robot._model:
            rng = np.random.default_rng(0)
            qs = [robot.random_configuration(rng) for _ in range(_EXACT_PAIR_SAMPLES)]
            cached = (robot._model, np.array(qs, dtype=float))
            _SAMPLES_CACHE[robot] = cached
        marked = kernel.mark_exact_pairs(cached[1])
        geom = robot._collision_model
        self._sphere_exact_pairs = tuple(
            (
                geom.geometryObjects[geom.collisionPairs[p].first].name,
                geom.geometryObjects[geom.collisionPairs[p].second].name,
            )
            for p in marked
        )
        if marked:
            logger.info(
                "sphere checker: %d self pairs whose spheres always touch are checked "
                "exactly by 'spheres_only': %s",
                len(marked),
                ", ".join(f"{a}-{b}" for a, b in self._sphere_exact_pairs),
            )

    @property
    def sphere_exact_pairs(self) -> tuple[tuple[str, str], ...]:
        """Self pairs (geometry names) the ``"spheres_only"`` checker tests exactly.

        Pairs whose spheres touch at every one of :data:`_EXACT_PAIR_SAMPLES` random
        configurations (seed 0) while their geometries are apart at one of them at least:
        the spheres' margin closes the gap between these neighbouring links (e.g. two pairs
        of the Unitree Z1), so counting their touch a collision would make every configuration
        collide. ``"spheres_only"`` tests them as ``"spheres"`` does (coal's exact narrow
        phase where their spheres touch). Set by :meth:`sphere_kernel`; empty before.
        """
        return self._sphere_exact_pairs

    @property
    def world_version(self) -> int:
        """:attr:`~taskspace.model.World.version` of the world the checker answers for.

        Objects that cache validity answers (roadmaps) record it and compare it with the
        current ``robot.world.version``.
        """
        self._sync()
        return self._world_version

    def _sync(self) -> None:
        """Rebuild the copies if the robot's world changed since they were made.

        The world's version changes at every obstacle or collision-pair change made through
        the robot; the identity and geometry-count checks also catch a replaced world or
        collision model.
        """
        robot = self.robot
        world = robot._world  # per query: the attributes, not the properties
        geom = robot._collision_model
        if (
            world._version != self._world_version
            or world is not self._world
            or geom is not self._geometry_model
            or geom.ngeoms != self._ngeoms
        ):
            logger.debug("robot world changed; rebuilding the collision checker")
            self.update_world()

    @property
    def geometry(self) -> str:
        """Which robot geometry is checked: ``"mesh"``, ``"convex hull"`` or ``"mixed"``."""
        kinds = set()
        objs = self.robot._collision_model.geometryObjects
        for i in range(self.robot.robot_geometry_count):
            name = type(objs[i].geometry).__name__
            if name.startswith("BVHModel"):
                kinds.add("mesh")
            elif name.startswith("Convex"):
                kinds.add("convex hull")
        if len(kinds) == 1:
            return kinds.pop()
        return "mixed" if kinds else "primitive"

    @property
    def pair_count(self) -> int:
        """Number of checked collision pairs (self pairs left by the SRDF plus obstacle pairs)."""
        return len(self.robot._collision_model.collisionPairs)

    # ------------------------------------------------------------------ queries
    def _batch(self, configurations: FloatArray, stop_in_batch: bool) -> BoolArray:
        """Collision flags (True = in collision) of the rows, one C++ call."""
        kernel = self._query_kernel()
        if kernel is not None:
            rows = np.ascontiguousarray(configurations)
            # The kernel holds the GIL: calls of at most KERNEL_CHUNK rows let other threads
            # run and Ctrl-C interrupt a large batch between two calls.
            if stop_in_batch:
                hits = np.zeros(rows.shape[0], dtype=bool)
                for start in range(0, rows.shape[0], KERNEL_CHUNK):
                    bad = kernel.first_invalid(rows[start : start + KERNEL_CHUNK])
                    if bad >= 0:
                        hits[start + bad :] = True  # rows after the first collision: not evaluated
                        break
                return hits
            if rows.shape[0] <= KERNEL_CHUNK:
                return np.asarray(kernel.collisions(rows), dtype=bool)
            out = np.empty(rows.shape[0], dtype=bool)
            for start in range(0, rows.shape[0], KERNEL_CHUNK):
                out[start : start + KERNEL_CHUNK] = kernel.collisions(
                    rows[start : start + KERNEL_CHUNK]
                )
            return out
        if not self._guess_off:
            self._no_cached_guess()
        qs = configurations.T  # column-major (nq, n) view: what Eigen expects, no copy
        if not qs.flags.f_contiguous:
            qs = np.asfortranarray(qs)
        if self._pool is not None:
            out = pin.computeCollisionsInParallel(1, self._pool, qs, True, stop_in_batch)
        else:
            out = pin.computeCollisionsInParallel(1, self._geometry_pool, qs, True, stop_in_batch)
        return np.asarray(out, dtype=bool)

    def _as_rows(self, configurations: Any) -> FloatArray:
        if (
            type(configurations) is np.ndarray
            and configurations.ndim == 2
            and configurations.dtype == np.float64
            and configurations.shape[1] == self._nq
        ):
            return configurations
        arr = np.asarray(configurations, dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self._nq:
            return as_matrix(configurations, (None, self._nq), "configurations")
        return arr

    def is_valid(self, q: Any) -> bool:
        """True if ``q`` (shape (nq,)) is collision-free; stops at the first colliding pair."""
        self._sync()
        if type(q) is np.ndarray and q.shape == (self._nq,) and q.dtype == np.float64:
            column = q.reshape(self._nq, 1)  # a view; one column is both C and F ordered
        else:
            column = self._as_rows(q)[:1].T.copy(order="F")
        self.checks += 1
        kernel = self._query_kernel()
        if kernel is not None:
            return bool(kernel.first_invalid(column.T) < 0)
        if not self._guess_off:
            self._no_cached_guess()
        if self._pool is not None:
            return not pin.computeCollisionsInParallel(1, self._pool, column, True, True)[0]
        return not bool(self._batch(column.T, True)[0])

    def are_valid(self, configurations: Any) -> BoolArray:
        """Collision-freeness of every row of ``configurations`` (shape (n, nq))."""
        self._sync()
        rows = self._as_rows(configurations)
        self.checks += rows.shape[0]
        return ~self._batch(rows, False)

    def first_invalid(self, configurations: Any) -> int:
        """Index of the first colliding row of ``configurations`` (shape (n, nq)), or -1.

        Rows are evaluated in order in one C++ call that stops at the first collision; only
        the evaluated rows are added to :attr:`checks`.
        """
        self._sync()
        rows = self._as_rows(configurations)
        if rows.shape[0] == 0:
            return -1
        kernel = self._query_kernel()
        if kernel is not None:
            bad = int(kernel.first_invalid(rows))
            self.checks += rows.shape[0] if bad < 0 else bad + 1
            return bad
        if not self._guess_off:
            self._no_cached_guess()
        if self._pool is not None and rows.flags.c_contiguous:
            hits = pin.computeCollisionsInParallel(1, self._pool, rows.T, True, True)
        else:
            hits = self._batch(rows, True)
        first = int(hits.argmax())
        if not hits[first]:
            self.checks += rows.shape[0]
            return -1
        self.checks += first + 1
        return first

    def colliding_pairs(self, q: Any) -> list[tuple[str, str]]:
        """Names of every colliding pair at ``q`` (exact narrow phase on all pairs)."""
        self._sync()
        qa = self._as_rows(q)[0]
        robot = self.robot
        geom = robot._collision_model
        if not self._guess_off:
            self._no_cached_guess()
        pin.computeCollisions(robot._model, self._data, geom, self._geom_data, qa, False)
        objs = geom.geometryObjects
        return [
            (objs[p.first].name, objs[p.second].name)
            for k, p in enumerate(geom.collisionPairs)
            if self._geom_data.collisionResults[k].isCollision()
        ]

    def explain(self, q: Any) -> str:
        """Why ``q`` is not free: the list of colliding pairs."""
        pairs = self.colliding_pairs(q)
        if not pairs:
            return "collision-free"
        return "colliding pairs: " + ", ".join(f"{a} <-> {b}" for a, b in pairs)

    def distance(self, q: Any) -> tuple[float, tuple[str, str]]:
        """Smallest distance [m] over the checked pairs and the pair that realizes it.

        Negative values are penetration depths. Cost: one narrow-phase distance query per
        pair (about 0.16 ms on Panda convex hulls, 5.6 ms on meshes).

        Raises:
            PlanningError: if the robot has no collision pair.
        """
        self._sync()
        qa = self._as_rows(q)[0]
        robot = self.robot
        geom = robot._collision_model
        if len(geom.collisionPairs) == 0:
            raise PlanningError(f"robot '{robot.name}' has no collision pair to measure")
        if not self._guess_off:
            self._no_cached_guess()
        k = int(pin.computeDistances(robot._model, self._data, geom, self._geom_data, qa))
        pair = geom.collisionPairs[k]
        objs = geom.geometryObjects
        dist = float(self._geom_data.distanceResults[k].min_distance)
        return dist, (objs[pair.first].name, objs[pair.second].name)


class FunctionChecker:
    """A :class:`ValidityChecker` from a vectorized predicate (2-D worlds, tests, examples).

    Args:
        is_free: ``is_free(Q) -> bool array``; ``Q`` has shape (n, d), True = free.
        explain: optional ``explain(q) -> str`` for error messages.

    Attributes:
        checks: number of configurations evaluated.
    """

    def __init__(self, is_free: Any, explain: Any = None) -> None:
        self._fn = is_free
        self._explain = explain
        self.checks = 0

    def are_valid(self, configurations: FloatArray) -> BoolArray:
        """Validity of every row."""
        rows = np.atleast_2d(np.asarray(configurations, dtype=float))
        self.checks += rows.shape[0]
        return np.asarray(self._fn(rows), dtype=bool).reshape(rows.shape[0])

    def first_invalid(self, configurations: FloatArray) -> int:
        """Index of the first invalid row, or -1 (counts rows up to that one)."""
        rows = np.atleast_2d(np.asarray(configurations, dtype=float))
        if rows.shape[0] == 0:
            return -1
        ok = np.asarray(self._fn(rows), dtype=bool).reshape(rows.shape[0])
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            self.checks += rows.shape[0]
            return -1
        self.checks += int(bad[0]) + 1
        return int(bad[0])

    def explain(self, q: FloatArray) -> str:
        """Reason why ``q`` is invalid."""
        if self._explain is not None:
            return str(self._explain(q))
        return "the configuration is in collision"
