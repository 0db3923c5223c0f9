"""QP backends on the project's own QPs, qpbenchmark style: success, time, KKT residuals.

Problem sets (each a sequence of QPs copied from a real run):

* ``ik panda`` / ``ik g1``: ``DifferentialIK`` steps (position task to random far targets,
  posture, joint position and velocity limits: boxes active), random configurations;
* ``id g1``: the inverse-dynamics QP of the G1 standing benchmark scene (CoM sway, hands,
  posture, two 6-D contacts with cones, torque and joint limits) along its own rollout;
* ``hierarchy g1``: every level QP of the 4-level cascade of the same scene with the hands
  sent 0.78 m away (out of reach: the cascade's levels hold active inequalities; in the
  benchmark scene itself the equality cascade already satisfies them and no QP is solved).

* ``general panda`` / ``general g1`` / ``general panda dampers``: QPs of the compiled general
  IK step (``DifferentialIK`` stacks with equality tasks or rows evaluated in Python) along
  a run: the ``ik`` suite's ``panda equality + rows`` scene (tcp orientation held by an
  equality task, two joint-space half-spaces), G1 with the hands moving, the feet held by
  equality tasks and the CoM's box edge 2 mm behind the CoM (active), and the ``ik``
  suite's Panda dampers scene (collision dampers, solved here by the general step), and the
  ``ik`` suite's weighted G1 scene with 60 random joint-space half-spaces 2 mm from the start
  (``general g1 60 rows``: many rows active at once). Besides
  the Python backends on the Python path's QPs of the same states, the compiled engines
  (``DifferentialIKOptions.native_general_engine``) solve them in C++ at each step: the
  dual active-set method warm-started with the previous step's active set (``active set``;
  ``cold``: without the warm start) and proxsuite's dense solver with its workspace kept
  per problem size and warm-started (``proxsuite``). Their time is the kernel's QP time
  (rows stacked, solve, KKT check; the QP's build is excluded, as for the Python backends),
  their residuals the kernel's KKT residuals, ``success`` the steps not declined. **Choice
  of the default** (``"auto"``): the active-set engine on every one of these classes; the
  project's default backend is proxsuite, but here the warm-started active-set method is
  faster on each class with the same answers (see these rows; the numbers of the last run
  are in the README and the session reports).

Each backend solves each set in sequence with one persistent :class:`QPSolver` per QP size (the
way the library uses it, one per cascade level: proxsuite warm-started, preconditioner kept,
unless the settings say otherwise), without the unconstrained
shortcut, fallbacks or relaxation, at the default tolerances (``eps_abs = eps_rel = 1e-9``;
cascade levels ``eps_rel = 1e-6``). ``success`` counts results whose KKT residuals meet the
tolerances (``SOLVED``); the residual columns are the largest over all results of the backend
(solved or not), as qpbenchmark reports them.

On the cascade set, proxsuite also runs with the settings the cascade uses
(:data:`~taskspace.qp.hierarchy.CASCADE_SOLVER_OPTIONS`: ``rho = 1e-11``, its own stopping
tolerance ``1e-8``, no duality-gap test, infeasibility tolerance ``1e-12``, a fresh workspace
per solve) and with each of those settings set back to proxsuite's default (``cascade - x``
rows): what each one is worth; and the cascade's default per-level solve (daqp kept when
exact to 1e-9, else proxsuite with those settings).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, Timing
from benchmarks.suites import ik as ik_suite
from benchmarks.suites import inverse_dynamics
from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import (
    CollisionAvoidance,
    Constraint,
    FeatureBounds,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.features.rows import InequalityRows
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Obstacle, Robot
from taskspace.qp import QPProblem, QPSolver, QPSolverOptions, QPStatus, available_backends
from taskspace.qp.hierarchy import CASCADE_SOLVER_OPTIONS, EXACT_FIRST_OPTIONS, HierarchySolver
from taskspace.tasks import Task

SUITE = "qp_backends"
IK_FRAMES = {"panda": "panda_hand_tcp", "g1": "left_rubber_hand"}


def ik_problems(name: str, count: int) -> list[QPProblem]:
    """DifferentialIK QPs at random configurations toward random far targets."""
    robot = Robot.load(name)
    frame = IK_FRAMES[name]
    rng = np.random.default_rng(0)
    task = Task(F.Position(robot, frame), np.zeros(3), gain=1.0)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot,
        [task, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=False),
    )
    out = []
    for _ in range(count):
        state = robot.state(robot.random_configuration(rng))
        task.set_target(robot.frame_placement(robot.random_configuration(rng), frame).translation)
        out.append(ik.build(state, 0.01).copy())
    return out


class _RecordingHierarchy(HierarchySolver):
    """The cascade with its default settings, keeping a copy of every level QP."""

    def __init__(self, store: list[QPProblem]) -> None:
        super().__init__()
        self.store = store

    def _solve_level(self, k: int, problem: QPProblem) -> Any:
        self.store.append(problem.copy())
        return super()._solve_level(k, problem)


def id_problems(steps: int, hierarchical: bool) -> list[QPProblem]:
    """The inverse-dynamics QPs (or cascade level QPs) along the benchmark scene's run."""
    robot, ctrl, com = inverse_dynamics.scene(hierarchical)
    store: list[QPProblem] = []
    if hierarchical:
        ctrl._hierarchy = _RecordingHierarchy(store)
        for hand in ctrl.tasks[1:3]:
            hand.set_target(hand.target * pin.SE3(np.eye(3), np.array([0.6, 0.0, 0.5])))
    c0 = com.target.copy()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    state = robot.state(q, v)
    dt = inverse_dynamics.DT
    for k in range(steps):
        com.set_target(c0 + np.array([0.0, 0.04 * np.sin(np.pi * k * dt), 0.0]))
        state.update(q, v)
        if not hierarchical:
            store.append(ctrl.build(state).copy())
        res = ctrl.solve(state)
        v = v + dt * res.a
        q = pin.integrate(robot.model, q, dt * v)
    return store


CASCADE_ABLATIONS: dict[str, dict[str, Any]] = {
    "proxsuite cascade": {},
    "proxsuite cascade - rho": {"proxsuite_rho": 1e-6},
    "proxsuite cascade - eps_rel 1e-8": {"proxsuite_eps_rel": None},
    "proxsuite cascade - no gap test": {"proxsuite_duality_gap": True},
    "proxsuite cascade - eps_primal_inf": {"proxsuite_eps_primal_inf": 1e-4},
    "proxsuite cascade - fresh workspace": {"proxsuite_warm_start": True},
}
"""Rows of the cascade set: the cascade's proxsuite settings, then each set back."""


def run_backend(
    backend: str,
    problems: list[QPProblem],
    eps_rel: float,
    options: QPSolverOptions | None = None,
) -> dict[str, Any]:
    """Solve the set in sequence with one persistent bare solver.

    ``options``: settings to start from (default: the defaults with ``eps_rel``); the
    backend, no fallbacks, no relaxation and no unconstrained shortcut are imposed.
    """
    base = options if options is not None else QPSolverOptions(eps_rel=eps_rel)
    bare = replace(
        base, backend=backend, fallbacks=(), relax_on_failure=False, try_unconstrained=False
    )
    # one solver per QP structure: the cascade keeps one per level, and its levels differ in
    # size (with one solver for all, every level would rebuild the workspace of the last)
    solvers: dict[tuple[int, int, int], QPSolver] = {}

    def solve(p: QPProblem) -> Any:
        solver = solvers.get(p.structure())
        if solver is None:
            solver = solvers[p.structure()] = QPSolver(bare)
        return solver.solve(p)

    return _run_set(problems, solve, with_backend=False)


def run_cascade_pipeline(problems: list[QPProblem]) -> dict[str, Any]:
    """The cascade's default per-level solve (HierarchySolver._solve_level) on the set:
    daqp kept when its KKT residuals meet 1e-9, else proxsuite with the cascade settings
    (no fallbacks, relaxation or shortcut, as for the other rows)."""
    exact = replace(EXACT_FIRST_OPTIONS, try_unconstrained=False)
    main = replace(
        CASCADE_SOLVER_OPTIONS, fallbacks=(), relax_on_failure=False, try_unconstrained=False
    )
    solvers: dict[tuple[int, int, int], tuple[QPSolver, QPSolver]] = {}

    def solve(p: QPProblem) -> Any:
        pair = solvers.get(p.structure())
        if pair is None:
            pair = solvers[p.structure()] = (QPSolver(exact), QPSolver(main))
        r = pair[0].solve(p)
        return r if r.success else pair[1].solve(p)

    return _run_set(problems, solve, with_backend=True)


def _run_set(
    problems: list[QPProblem], solve: Callable[[QPProblem], Any], with_backend: bool
) -> dict[str, Any]:
    """Time ``solve`` on each QP of the set; success count, largest KKT residuals, statuses."""
    times = np.empty(len(problems))
    solved = 0
    primal = dual = gap = 0.0
    statuses: dict[str, int] = {}
    for i, p in enumerate(problems):
        t0 = time.perf_counter()
        r = solve(p)
        times[i] = time.perf_counter() - t0
        solved += r.status is QPStatus.SOLVED
        key = f"{r.status.value} {r.backend}" if with_backend else r.status.value
        statuses[key] = statuses.get(key, 0) + 1
        if np.isfinite(r.kkt.primal):
            primal = max(primal, r.kkt.primal)
            dual = max(dual, r.kkt.dual)
            gap = max(gap, r.kkt.duality_gap)
    return {
        "times": times,
        "success": f"{solved}/{len(problems)}",
        "primal": primal,
        "dual": dual,
        "gap": gap,
        "statuses": statuses,
    }


COMPILED_ENGINES = (
    ("active set", "active_set", True),
    ("active set cold", "active_set", False),
    ("proxsuite", "proxsuite", True),
)
"""Compiled rows of the general sets: (row name, engine, warm start)."""


def _general_panda() -> tuple[Robot, Any, list[Any], list[Any], list[Any], Any, float]:
    """The ``ik`` suite's ``panda equality + rows`` scene."""
    robot = Robot.load("panda")
    state = robot.state(robot.q_default)
    position, p0, orientation, posture, constraints, _ = ik_suite.panda_general_scene(robot, state)

    def target(k: int) -> None:
        position.set_target(p0 + ik_suite.hand_offset(k))

    return robot, state, [position, posture], constraints, [orientation], target, ik_suite.DT


def _general_g1() -> tuple[Robot, Any, list[Any], list[Any], list[Any], Any, float]:
    """G1: hands moving (the ``ik`` suite's offsets), feet as equality tasks, CoM, posture,
    limits, the CoM's box over the feet with its front edge 2 mm behind the CoM (active)."""
    robot = Robot.load("g1")
    groups, moving = ik_suite.g1_tasks(robot)
    state = robot.state(robot.q_default)
    feet = np.array(
        [state.frame_placement(robot.frame_id(f)).translation[:2] for f in ik_suite.G1_FEET]
    )
    support = FeatureBounds(
        F.CenterOfMass(robot),
        [feet[:, 0].min() - 0.05, feet[:, 1].min(), -np.inf],
        [float(state.com()[0]) - 0.002, feet[:, 1].max(), np.inf],
        name="CoM over the feet",
    )
    tasks = [*groups["hands"], *groups["com"], *groups["posture"]]
    constraints = [JointPositionLimits(robot), JointVelocityLimits(robot), support]

    def target(k: int) -> None:
        ik_suite.move_targets(moving, k)

    return robot, state, tasks, constraints, groups["feet"], target, ik_suite.DT


def _general_dampers(steps: int) -> tuple[Robot, Any, list[Any], list[Any], list[Any], Any, float]:
    """The ``ik`` suite's Panda dampers scene (tcp pose to the goal past the ball)."""
    robot = Robot.load("panda", convex_collision=True)
    tcp = robot.end_effectors[0]
    state = robot.state(robot.q_default)
    start = state.frame_placement(robot.frame_id(tcp)).copy()
    goal = start.copy()
    goal.translation = start.translation + np.array(ik_suite.DEMO_GOAL)
    radius, offset = ik_suite.DEMO_BALL
    robot.add_obstacle(Obstacle.sphere("ball", radius, start.translation + np.array(offset)))
    pose = Task(F.FramePose(robot, tcp), weight=1.0, gain=0.5, name="tcp")
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-5, name="posture")
    avoid = CollisionAvoidance(robot, safety_distance=0.02, influence_distance=0.12, gain=0.5)
    constraints = [JointPositionLimits(robot), JointVelocityLimits(robot), avoid]

    def target(k: int) -> None:
        s = min(1.0, k / (0.75 * steps))
        pose.set_target(pin.SE3.Interpolate(start, goal, 0.5 * (1 - np.cos(np.pi * s))))

    return robot, state, [pose, posture], constraints, [], target, ik_suite.DEMO_DT


class _JointRows(Constraint):
    """A user's joint-space half-spaces ``A q_j <= b`` on the joint coordinates ``q_j`` (the
    configuration after the free flyer's 7): rows ``A dq_j <= b - A q_j``."""

    def __init__(self, robot: Robot, A: np.ndarray, b: np.ndarray) -> None:
        super().__init__(robot, "joint half-spaces")
        self.A, self.b = A, b
        self._start = robot.nq - A.shape[1]
        self._lower = np.full(len(b), -np.inf)

    def inequalities(self, state: Any, dt: float) -> InequalityRows:
        C = np.zeros((len(self.b), self.robot.nv))
        C[:, self.robot.nv - self.A.shape[1] :] = self.A
        return InequalityRows(C, self._lower, self.b - self.A @ state.q[self._start :])


def _general_g1_rows() -> tuple[Robot, Any, list[Any], list[Any], list[Any], Any, float]:
    """The weighted G1 scene of the ``ik`` suite (feet, CoM, hands, posture as tasks) with 60
    random joint-space half-spaces 2 mm from the start: about 28 rows active per step."""
    robot = Robot.load("g1")
    groups, moving = ik_suite.g1_tasks(robot)
    state = robot.state(robot.q_default)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((60, robot.nv - 6))
    rows = _JointRows(robot, A, A @ robot.q_default[7:] + 0.002)
    tasks = [t for g in groups.values() for t in g]
    constraints = [JointPositionLimits(robot), JointVelocityLimits(robot), rows]

    def target(k: int) -> None:
        ik_suite.move_targets(moving, k)

    return robot, state, tasks, constraints, [], target, ik_suite.DT


def general_sets(scene: str, steps: int) -> tuple[list[QPProblem], dict[str, dict[str, Any]]]:
    """One run of a general-step scene: the Python path's QP at each state, and each
    compiled engine's results at the same states (the run follows the first engine)."""
    module: Any = ik_kernel()
    if scene == "general panda":
        robot, state, tasks, constraints, equality, target, dt = _general_panda()
    elif scene == "general g1":
        robot, state, tasks, constraints, equality, target, dt = _general_g1()
    elif scene == "general g1 60 rows":
        robot, state, tasks, constraints, equality, target, dt = _general_g1_rows()
    else:
        robot, state, tasks, constraints, equality, target, dt = _general_dampers(steps)
    python = DifferentialIK(
        robot, tasks, constraints, equality, options=DifferentialIKOptions(native=False)
    )
    engines = [e for e in COMPILED_ENGINES if module is not None and e[1] in module.GENERAL_ENGINES]
    solvers: list[Any] = []
    for _, engine, warm in engines:
        ik: Any = DifferentialIK(
            robot, tasks, constraints, equality, DifferentialIKOptions(native_general_engine=engine)
        )
        assert ik.native and ik._native is not None
        if ik._native._general is None:  # dampers only: the general step solves them here
            ik._native._general = module.GeneralIKStep()
            ik._native._general.set_engine(module.GENERAL_ENGINES.index(engine))
        ik._native._general.set_warm_start(warm)
        solvers.append(ik)
    # a solver run first at each state, not recorded: whichever engine ran first paid ~2 us
    # more (the state's data and the kernel's code out of the caches), an order effect
    warm_up: Any = DifferentialIK(robot, tasks, constraints, equality)
    if warm_up.native and warm_up._native._general is None:
        warm_up._native._general = module.GeneralIKStep()
    problems: list[QPProblem] = []
    out: dict[str, dict[str, Any]] = {
        name: {"times": [], "solved": 0, "primal": 0.0, "dual": 0.0, "gap": 0.0, "statuses": {}}
        for name, _, _ in engines
    }
    q = state.q.copy()
    for k in range(steps):
        target(k)
        state.update(q)
        problems.append(python.build(state, dt).copy())
        dq = None
        warm_up.solve(state, dt)
        for (name, _, _), ik in zip(engines, solvers):
            r = ik.solve(state, dt)
            o = out[name]
            key = r.native_declined or "solved"
            o["statuses"][key] = o["statuses"].get(key, 0) + 1
            if not r.native_declined:
                o["times"].append(r.solve_time)
                o["solved"] += r.qp.kkt.within(1e-9, 1e-9)
                o["primal"] = max(o["primal"], r.qp.kkt.primal)
                o["dual"] = max(o["dual"], r.qp.kkt.dual)
                o["gap"] = max(o["gap"], r.qp.kkt.duality_gap)
            dq = r.dq if dq is None else dq
        q = pin.integrate(robot.model, q, dq if dq is not None else python.solve(state, dt).dq)
    for (name, _, _), ik in zip(engines, solvers):
        o = out[name]
        o["times"] = np.array(o["times"])
        o["success"] = f"{o['solved']}/{steps}"
        o["warm"] = ik._native._general.warm_stats()
    return problems, out


def run(quick: bool) -> list[Row]:
    """Every available backend on every problem set."""
    n = 20 if quick else 200
    sets = {
        "ik panda": (ik_problems("panda", n), 1e-9),
        "ik g1": (ik_problems("g1", n), 1e-9),
        "id g1": (id_problems(n, hierarchical=False), 1e-9),
        "hierarchy g1": (id_problems(max(n // 4, 5), hierarchical=True), 1e-6),
    }
    compiled: dict[str, dict[str, dict[str, Any]]] = {}
    for scene, steps in (
        ("general panda", 300 if quick else 1500),
        ("general g1", 60 if quick else 300),
        ("general panda dampers", 100 if quick else 400),
        ("general g1 60 rows", 30 if quick else 150),
    ):
        problems, compiled[scene] = general_sets(scene, steps)
        sets[scene] = (problems, 1e-9)
    rows = []
    for scene, (problems, eps_rel) in sets.items():
        if not problems:
            rows.append(Row(SUITE, scene, "-", None, note="no QP reached the backends"))
            continue
        methods: list[tuple[str, str, QPSolverOptions | None]] = [
            (b, b, None) for b in available_backends()
        ]
        if scene == "hierarchy g1" and "proxsuite" in available_backends():
            methods += [
                (name, "proxsuite", replace(CASCADE_SOLVER_OPTIONS, **change))
                for name, change in CASCADE_ABLATIONS.items()
            ]
        if scene == "hierarchy g1":
            out = run_cascade_pipeline(copy.copy(problems))
            rows.append(
                Row(
                    SUITE,
                    scene,
                    "cascade default (daqp exact, then proxsuite cascade)",
                    Timing.from_samples(out["times"]),
                    {
                        "success": out["success"],
                        "max_primal_residual": f"{out['primal']:.1e}",
                        "max_dual_residual": f"{out['dual']:.1e}",
                        "max_duality_gap": f"{out['gap']:.1e}",
                    },
                    ratio_to="daqp",
                    note=f"{len(problems)} QPs; statuses {out['statuses']}",
                )
            )
        for name, o in compiled.get(scene, {}).items():
            rows.append(
                Row(
                    SUITE,
                    scene,
                    f"compiled {name}",
                    Timing.from_samples(o["times"]),
                    {
                        "success": o["success"],
                        "max_primal_residual": f"{o['primal']:.1e}",
                        "max_dual_residual": f"{o['dual']:.1e}",
                        "max_duality_gap": f"{o['gap']:.1e}",
                    },
                    ratio_to="daqp",
                    note=f"{len(problems)} steps; statuses {o['statuses']}; (warm start kept, "
                    f"missed, proxsuite workspaces made) {o['warm']}",
                )
            )
        for method, backend, options in methods:
            out = run_backend(backend, copy.copy(problems), eps_rel, options)
            rows.append(
                Row(
                    SUITE,
                    scene,
                    method,
                    Timing.from_samples(out["times"]),
                    {
                        "success": out["success"],
                        "max_primal_residual": f"{out['primal']:.1e}",
                        "max_dual_residual": f"{out['dual']:.1e}",
                        "max_duality_gap": f"{out['gap']:.1e}",
                    },
                    ratio_to="daqp",
                    note=f"{len(problems)} QPs; statuses {out['statuses']}",
                )
            )
    return rows
