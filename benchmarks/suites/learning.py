"""Learning suite: Gymnasium env throughput, fitted value iteration, CMA-ES on the cart-pole.

Scenes (built separately from timing):
* ``pendulum_step`` / ``cartpole_step``: one ``step`` of ``taskspace/Pendulum-v0`` and
  ``taskspace/CartPole-v0`` (Pinocchio ABA) against Gymnasium's ``Pendulum-v1`` and
  ``CartPole-v1`` (closed forms in Python), unwrapped, interleaved in the same process.
* ``cartpole_batched_1024``: one step of 1,024 cart-poles, our ``CartPoleVectorEnv`` against
  Gymnasium's own ``CartPoleVectorEnv`` (``make_vec(..., vectorization_mode=
  "vector_entry_point")``); steps/s per core in ``extra``. Ours twice, interleaved with
  theirs: the default (URDF point-mass pole, 2 semi-implicit Euler substeps) and
  ``model="gymnasium"`` (CartPole-v1's equations, 1 explicit Euler step: the same work).
* ``panda_reach_step``: one ``step`` of ``PandaReachEnv`` (unwrapped; TCP forward kinematics
  and an exact mesh collision check per step) beside one step of Gymnasium's MuJoCo
  ``Reacher-v5`` (a 2-link planar arm, frame skip 2) run by ``benchmarks/peers/
  mujoco_reacher.py`` in the ``sb3`` peer environment (same run, another process; a different,
  smaller task: the row says what a MuJoCo reaching step costs, not a like-for-like ratio).
* ``panda_reach_batched_256`` (quick: 64): one step of 256 Panda reach copies, our
  ``PandaReachVectorEnv`` (batched forward kinematics, one collision-kernel call) against
  gymnasium's ``SyncVectorEnv`` over 256 ``PandaReachEnv`` (interleaved in this process), and
  the peer's ``SyncVectorEnv`` of 256 MuJoCo reachers; steps/s per core in ``extra``.
* ``pendulum_ppo`` (only with ``TASKSPACE_BENCH_PPO=1``: about 10 minutes): Stable-Baselines3
  PPO with the RL Zoo's ``Pendulum-v1`` hyperparameters for 100,000 steps (quick: 20,000) on
  ``taskspace/Pendulum-v0`` and on ``Pendulum-v1`` (``benchmarks/peers/sb3_ppo.py`` in the
  ``sb3`` peer environment): wall time of a training run, the deterministic evaluation return
  (10 episodes), the time spent in the environments' ``step``.
* ``pendulum_fvi_101``: fitted value iteration of the pendulum swing-up on a 101 x 101 grid
  (quick: 41 x 41), 9 torques in [-4, 4] N m, dt 0.05 s, gamma = exp(-0.2 dt), stopped when
  ``max |J_{k+1} - J_k| <= 1e-4``; Drake's ``FittedValueIteration`` on the same grid, torques,
  time step, discount, tolerance and pendulum (1 kg at 1 m, no damping) when the ``drake`` peer
  environment is installed (its grid includes the end point 2 pi of the periodic angle; it
  integrates with its simulator's default integrator, ours with RK4).
* ``cartpole_cma_es``: CMA-ES (pycma) on the 4-parameter linear policy ``push right iff
  theta^T obs > 0``, population 10, sigma 0.5, over 10 seeds (quick: 3): environment steps
  until a candidate first balances a whole 500-step episode, at most 100 rollouts (<= 50,000
  steps), on our cart-pole and on ``CartPole-v1``; median and success count in ``extra``.
* ``via_point_power`` / ``via_point_pi2`` / ``via_point_pi2_per_step`` / ``via_point_cma_es`` /
  ``via_point_mu_lambda_es``: PoWER, PI^2 (episodic, and per time step with the DMP basis
  activations, also ``via_point_pi2_per_step_projected`` with the paper's projection of the
  noise onto the basis), CMA-ES (pycma) and the (mu, lambda)-ES on the 2-D DMP via-point task
  (8 basis functions per dimension, population 10, 4 elites, sigma 20 decaying by 0.93;
  CMA-ES adapts its own sigma),
  over 5 seeds (quick: 2): rollouts until a rollout first passes within 2 cm of the via point,
  and the via-point error of the final mean parameters after 40 updates.
* ``dmp_step`` / ``dmp_rollout_1000``: a 3-D discrete DMP (30 basis functions) learned from
  the same demonstration; one online step (ours: ``DMPTaskTarget.step``, which also writes the
  target of a 3-D task; theirs: ``DMP.step``) and a 1,001-step open-loop rollout at dt 1 ms,
  against the ``movement-primitives`` package (peer environment ``movement_primitives``).
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import taskspace.learning.envs  # noqa: F401  (registers the taskspace/* ids)
from benchmarks.common import Row, Timing, measure_interleaved, peer_python, run_peer
from taskspace.features import JointConfiguration
from taskspace.learning import (
    DiscreteDMP,
    DMPOptions,
    DMPTaskTarget,
    Episode,
    PolicySearchOptions,
    ViaPointTask,
    cma_es,
    mu_lambda_es,
    pi2,
    power,
)
from taskspace.learning.envs import PandaReachEnv, PandaReachVectorEnv
from taskspace.model import Robot
from taskspace.optimal_control import (
    FittedValueIterationOptions,
    PendulumSwingUp,
    ValueIterationOptions,
    fitted_value_iteration,
    make_grid,
)
from taskspace.tasks import Task

SUITE = "learning"

FVI_DT = 0.05
FVI_RHO = 0.2
FVI_TOL = 1e-4
FVI_ACTIONS = 9

DRAKE_FVI = """
import json, sys, time
import numpy as np
from pydrake.examples import PendulumPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.controllers import DynamicProgrammingOptions, FittedValueIteration

n, actions, dt, rho, tol = int(sys.argv[1]), int(sys.argv[2]), *map(float, sys.argv[3:6])
plant = PendulumPlant()
simulator = Simulator(plant)
params = plant.get_mutable_parameters(simulator.get_mutable_context())
params.set_mass(1.0)
params.set_length(1.0)
params.set_damping(0.0)
params.set_gravity(9.80665)
options = DynamicProgrammingOptions()
options.periodic_boundary_conditions = [
    DynamicProgrammingOptions.PeriodicBoundaryCondition(0, 0.0, 2 * np.pi)
]
options.discount_factor = float(np.exp(-rho * dt))
options.convergence_tol = tol
options.input_port_index = plant.get_input_port(0).get_index()
state_grid = [set(np.linspace(0.0, 2 * np.pi, n)), set(np.linspace(-8.0, 8.0, n))]
input_grid = [set(np.linspace(-4.0, 4.0, actions))]


def cost(context):
    x = context.get_continuous_state_vector().CopyToVector()
    d = (x[0] - np.pi + np.pi) % (2 * np.pi) - np.pi
    u = plant.EvalVectorInput(context, 0)[0]
    return d * d + 0.1 * x[1] ** 2 + 0.01 * u * u


samples = []
for _ in range(int(sys.argv[6])):
    t0 = time.perf_counter()
    FittedValueIteration(simulator, cost, state_grid, input_grid, dt, options)
    samples.append(time.perf_counter() - t0)
print(json.dumps({"samples_s": samples}))
"""


DMP_PEER = """
import json, sys, time
import numpy as np
from movement_primitives.dmp import DMP

T = np.linspace(0, 1, 201)
s = T / T[-1]
mj = 10 * s**3 - 15 * s**4 + 6 * s**5
Y = np.stack([0.3 * mj, 0.5 * np.sin(np.pi * T), -0.2 * mj], axis=1)
dmp = DMP(n_dims=3, execution_time=1.0, dt=0.001, n_weights_per_dim=30)
dmp.imitate(T, Y)
dmp.configure(start_y=Y[0], goal_y=Y[-1])
rollouts = []
for _ in range(int(sys.argv[1])):
    t0 = time.perf_counter()
    dmp.open_loop()
    rollouts.append(time.perf_counter() - t0)
dmp.reset()
y, yd = Y[0].copy(), np.zeros(3)
steps = []
for _ in range(900):
    t0 = time.perf_counter()
    y, yd = dmp.step(y, yd)
    steps.append(time.perf_counter() - t0)
print(json.dumps({"rollout_s": rollouts, "step_s": steps}))
"""


def _run_inline_peer(peer: str, source: str, args: list[str]) -> tuple[Any, str]:
    """Run ``source`` in the peer's environment; its last stdout line is JSON."""
    exe = peer_python(peer)
    if exe is None:
        return None, f"{peer} peer environment missing (make bench-peers)"
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / f"{peer}_peer.py"
        script.write_text(source)
        proc = subprocess.run(
            [str(exe), str(script), *args], capture_output=True, text=True, timeout=1800
        )
    if proc.returncode != 0:
        return None, f"{peer} failed: {proc.stderr[-300:]}"
    return json.loads(proc.stdout.strip().splitlines()[-1]), ""


def scene_single(env_id: str) -> tuple[Any, Any]:
    """The unwrapped env (reset, seeded) and a fixed action stream."""
    env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(256)]
    return env, actions


def _stepper(env: Any, actions: list[Any]) -> Any:
    counter = iter(range(10**12))

    def step() -> None:
        _, _, term, trunc, _ = env.step(actions[next(counter) & 255])
        if term or trunc:
            env.reset()

    return step


def scene_batched(num_envs: int, **kwargs: Any) -> tuple[Any, Any, np.ndarray]:
    """Ours (``kwargs``: e.g. ``model="gymnasium"``) and Gymnasium's vector cart-poles (reset)
    and a fixed action batch."""
    ours = gym.make_vec(
        "taskspace/CartPole-v0",
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        **kwargs,
    )
    theirs = gym.make_vec("CartPole-v1", num_envs=num_envs, vectorization_mode="vector_entry_point")
    ours.reset(seed=0)
    theirs.reset(seed=0)
    acts = np.random.default_rng(0).integers(0, 2, (64, num_envs))
    return ours, theirs, acts


def _env_rows(quick: bool) -> list[Row]:
    rows: list[Row] = []
    rounds = 30 if quick else 200
    for scene, ours_id, peer_id in (
        ("pendulum_step", "taskspace/Pendulum-v0", "Pendulum-v1"),
        ("cartpole_step", "taskspace/CartPole-v0", "CartPole-v1"),
    ):
        fns = [_stepper(*scene_single(ours_id)), _stepper(*scene_single(peer_id))]
        t_ours, t_peer = measure_interleaved(fns, warmup=200, rounds=rounds, block=50)
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace",
                t_ours,
                {"steps_per_s": 1e6 / t_ours.median_us},
                ratio_to=f"gymnasium {peer_id}",
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                f"gymnasium {peer_id}",
                t_peer,
                {"steps_per_s": 1e6 / t_peer.median_us},
            )
        )
    n = 1024
    ours, theirs, acts = scene_batched(n)
    ours_g = scene_batched(n, model="gymnasium")[0]
    c1, c2, c3 = iter(range(10**12)), iter(range(10**12)), iter(range(10**12))
    t_ours, t_peer, t_g = measure_interleaved(
        [
            lambda: ours.step(acts[next(c1) & 63]),
            lambda: theirs.step(acts[next(c2) & 63]),
            lambda: ours_g.step(acts[next(c3) & 63]),
        ],
        warmup=20,
        rounds=20 if quick else 100,
        block=10,
    )
    for method, t in (
        ("taskspace", t_ours),
        ("taskspace model=gymnasium", t_g),
        ("gymnasium CartPoleVectorEnv", t_peer),
    ):
        rows.append(
            Row(
                SUITE,
                f"cartpole_batched_{n}",
                method,
                t,
                {"copies": n, "steps_per_s": n * 1e6 / t.median_us, "target_steps_per_s": 20000},
                ratio_to="gymnasium CartPoleVectorEnv" if method.startswith("taskspace") else None,
            )
        )
    return rows


REACHER = "gymnasium Reacher-v5 (mujoco)"


def scene_panda_batched(num_envs: int, robot: Robot) -> tuple[PandaReachVectorEnv, Any, np.ndarray]:
    """Our batched Panda reach, gymnasium's SyncVectorEnv of the single env, an action stream."""
    ours = PandaReachVectorEnv(num_envs, robot=robot)
    sync = gym.vector.SyncVectorEnv([lambda: PandaReachEnv(robot=robot)] * num_envs)
    ours.reset(seed=0)
    sync.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-0.3, 0.3, (16, num_envs, 7)).astype(np.float32)
    return ours, sync, acts


def _panda_rows(quick: bool) -> list[Row]:
    n = 64 if quick else 256
    rounds = 30 if quick else 200
    robot = Robot.load("panda")
    single = PandaReachEnv(robot=robot)
    single.reset(seed=0)
    single.action_space.seed(0)
    t_single = measure_interleaved(
        [_stepper(single, [single.action_space.sample() for _ in range(256)])],
        warmup=200,
        rounds=rounds,
        block=50,
    )[0]
    try:
        peer = run_peer("sb3", "mujoco_reacher.py", [str(rounds), str(n)])
        note = "" if peer else "sb3 peer environment missing (see benchmarks/peers/sb3_ppo.py)"
    except RuntimeError as err:
        peer, note = None, str(err)[-300:]
    t_reacher = Timing.from_samples(peer["single"]) if peer else None
    t_reacher_vec = Timing.from_samples(peer[f"sync_{n}"]) if peer else None
    mj = {"mujoco": peer["mujoco"]} if peer else {}
    rows = [
        Row(
            SUITE,
            "panda_reach_step",
            "taskspace",
            t_single,
            {"steps_per_s": 1e6 / t_single.median_us},
            ratio_to=REACHER,
        ),
        Row(
            SUITE,
            "panda_reach_step",
            REACHER,
            t_reacher,
            {"steps_per_s": 1e6 / t_reacher.median_us, **mj} if t_reacher else {},
            note=note or "another process, same run; 2-link planar arm",
        ),
    ]
    ours, sync, acts = scene_panda_batched(n, robot)
    c1, c2 = iter(range(10**12)), iter(range(10**12))
    t_ours, t_sync = measure_interleaved(
        [lambda: ours.step(acts[next(c1) & 15]), lambda: sync.step(acts[next(c2) & 15])],
        warmup=5,
        rounds=10 if quick else 40,
        block=3,
    )
    scene = f"panda_reach_batched_{n}"
    sync_name = "gymnasium SyncVectorEnv (PandaReachEnv)"
    for method, t in (
        ("taskspace", t_ours),
        (sync_name, t_sync),
        (f"{REACHER} SyncVectorEnv", t_reacher_vec),
    ):
        rows.append(
            Row(
                SUITE,
                scene,
                method,
                t,
                {"copies": n, "steps_per_s": n * 1e6 / t.median_us} if t else {},
                ratio_to=sync_name if method == "taskspace" else None,
                note=note if t is None else "",
            )
        )
    return rows


def _ppo_rows(quick: bool) -> list[Row]:
    ids = ("taskspace/Pendulum-v0", "Pendulum-v1")
    names = {"taskspace/Pendulum-v0": "taskspace + sb3 PPO", "Pendulum-v1": "gymnasium + sb3 PPO"}
    if os.environ.get("TASKSPACE_BENCH_PPO", "") in ("", "0"):
        note = "set TASKSPACE_BENCH_PPO=1 to run (about 10 min; sb3 peer environment)"
        return [Row(SUITE, "pendulum_ppo", names[i], None, note=note) for i in ids]
    timesteps = 20_000 if quick else 100_000
    try:
        out = run_peer("sb3", "sb3_ppo.py", [str(timesteps), "1", *ids], timeout=3600)
        note = "" if out else "sb3 peer environment missing (see benchmarks/peers/sb3_ppo.py)"
    except RuntimeError as err:
        out, note = None, str(err)[-300:]
    rows = []
    for env_id in ids:
        res = out[env_id] if out else None
        rows.append(
            Row(
                SUITE,
                "pendulum_ppo",
                names[env_id],
                Timing.from_samples(res["wall_s"]) if res else None,
                {
                    "timesteps": timesteps,
                    "eval_return": [round(r, 1) for r in res["eval_return"]],
                    "last_training_return": [round(c[-1], 1) if c else None for c in res["curve"]],
                    "env_step_s": [round(t, 2) for t in res["env_step_s"]],
                    **out["versions"],
                }
                if res and out
                else {},
                ratio_to=names["Pendulum-v1"] if env_id.startswith("taskspace") else None,
                note=note or "timing: one training run; torque bound 5 N m (ours) vs 2 N m",
            )
        )
    return rows


def scene_fvi(n: int) -> tuple[Any, ...]:
    """Grid, torques, dynamics, cost and options of the pendulum swing-up."""
    prob = PendulumSwingUp()
    grid = make_grid(
        [np.linspace(0, 2 * np.pi, n + 1)[:-1], np.linspace(-8, 8, n)], periods=[2 * np.pi, 0.0]
    )
    options = FittedValueIterationOptions(
        dt=FVI_DT,
        substeps=1,
        discount_rate=FVI_RHO,
        value_iteration=ValueIterationOptions(tolerance=FVI_TOL, max_iterations=20_000),
    )
    return grid, np.linspace(-4, 4, FVI_ACTIONS), prob.dynamics, prob.cost, options


def _drake_fvi(n: int, repeat: int) -> tuple[Timing | None, str]:
    args = [str(n), str(FVI_ACTIONS), str(FVI_DT), str(FVI_RHO), str(FVI_TOL), str(repeat)]
    out, note = _run_inline_peer("drake", DRAKE_FVI, args)
    return (Timing.from_samples(out["samples_s"]) if out else None), note


def _fvi_rows(quick: bool) -> list[Row]:
    n = 41 if quick else 101
    repeat = 1 if quick else 3
    scene = scene_fvi(n)
    samples, res = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = fitted_value_iteration(*scene[:4], scene[4])
        samples.append(time.perf_counter() - t0)
    assert res is not None
    t_drake, note = _drake_fvi(n, repeat)
    extra = {
        "grid": [n, n],
        "actions": FVI_ACTIONS,
        "iterations": res.iterations,
        "converged": res.success,
        "median_abs_hjb_residual": float(np.median(np.abs(res.hjb_residual))),
    }
    name = f"pendulum_fvi_{n}"
    return [
        Row(SUITE, name, "taskspace", Timing.from_samples(samples), extra, ratio_to="drake"),
        Row(SUITE, name, "drake", t_drake, {"grid": [n, n], "actions": FVI_ACTIONS}, note=note),
    ]


def _cma_es_steps(env_id: str, seed: int, max_rollouts: int) -> tuple[int | None, int]:
    """Environment steps until a rollout first returns 500 (``None``: never) and in total."""
    env = gym.make(env_id)
    counter = {"steps": 0, "first": None}

    def rollout(theta: np.ndarray, rollout_seed: int) -> Episode:
        obs, _ = env.reset(seed=int(rollout_seed))
        total, steps = 0.0, 0
        while True:
            obs, r, term, trunc, _ = env.step(int(np.dot(theta, obs) > 0))
            total += float(r)
            steps += 1
            if term or trunc:
                break
        counter["steps"] += steps
        if total >= 500 and counter["first"] is None:
            counter["first"] = counter["steps"]
        return Episode(
            total_return=total,
            log_likelihood_gradient=np.zeros(4),
            rewards=np.zeros(0),
            steps=steps,
        )

    cma_es(
        rollout,
        np.zeros(4),
        PolicySearchOptions(
            iterations=max_rollouts // 10,
            population=10,
            exploration=0.5,
            seed=seed,
            target_return=500.0,
            max_rollouts=max_rollouts,
        ),
    )
    return counter["first"], counter["steps"]


def _cma_rows(quick: bool) -> list[Row]:
    seeds = range(3 if quick else 10)
    rows = []
    for env_id in ("taskspace/CartPole-v0", "CartPole-v1"):
        firsts, totals, wall = [], [], []
        for seed in seeds:
            t0 = time.perf_counter()
            first, total = _cma_es_steps(env_id, seed, 100)
            wall.append(time.perf_counter() - t0)
            firsts.append(first)
            totals.append(total)
        reached = [f for f in firsts if f is not None]
        # Median over seeds, a seed that never reached 500 counting as infinitely many steps.
        ranked = sorted(f if f is not None else np.inf for f in firsts)
        median = float(np.median(ranked))
        rows.append(
            Row(
                SUITE,
                "cartpole_cma_es",
                "taskspace" if env_id.startswith("taskspace") else "gymnasium CartPole-v1",
                Timing.from_samples(wall),
                {
                    "seeds": len(firsts),
                    "reached_500": len(reached),
                    "median_steps_to_500": median if np.isfinite(median) else None,
                    "steps_to_500": firsts,
                    "target_steps": 50000,
                    "within_target": bool(np.isfinite(median) and median <= 50000),
                },
                note="timing: wall time of one CMA-ES run (<= 100 rollouts)",
            )
        )
    return rows


def scene_via_point() -> ViaPointTask:
    """The via-point task of the tests: pass (0.5, 0.8) at 0.5 s (demonstrated: (0.5, 0.5))."""
    t = np.linspace(0, 1, 101)
    mj = 10 * t**3 - 15 * t**4 + 6 * t**5
    dmp = DiscreteDMP.fit(t, np.stack([mj, mj], axis=1), DMPOptions(num_basis=8))
    return ViaPointTask(dmp=dmp, via_time=0.5, via_point=np.array([0.5, 0.8]))


def _via_point_rows(quick: bool) -> list[Row]:
    rows = []
    activations = scene_via_point().activations()

    def pi2_per_step(rollout: Any, theta0: np.ndarray, options: PolicySearchOptions) -> Any:
        return pi2(rollout, theta0, options, activations=activations)

    def pi2_projected(rollout: Any, theta0: np.ndarray, options: PolicySearchOptions) -> Any:
        return pi2(rollout, theta0, options, activations=activations, projection_blocks=2)

    methods = (
        ("power", power),
        ("pi2", pi2),
        ("pi2_per_step", pi2_per_step),
        ("pi2_per_step_projected", pi2_projected),
        ("cma_es", cma_es),
        ("mu_lambda_es", mu_lambda_es),
    )
    for name, method in methods:
        firsts: list[int | None] = []
        finals, wall = [], []
        for seed in range(2 if quick else 5):
            task = scene_via_point()
            state: dict[str, Any] = {"rollouts": 0, "first": None}

            def rollout(theta: np.ndarray, s: int, task: ViaPointTask = task, state: Any = state):
                state["rollouts"] += 1
                if state["first"] is None and task.via_error(theta) <= 0.02:
                    state["first"] = state["rollouts"]
                return task.rollout(theta, s)

            t0 = time.perf_counter()
            res = method(
                rollout,
                task.dmp.weights.ravel(),
                PolicySearchOptions(
                    iterations=40,
                    population=10,
                    elite=4,
                    exploration=20.0,
                    exploration_decay=0.93,
                    seed=seed,
                ),
            )
            wall.append(time.perf_counter() - t0)
            firsts.append(state["first"])
            finals.append(task.via_error(res.parameters))
        ranked = sorted(f if f is not None else np.inf for f in firsts)
        median = float(np.median(ranked))
        rows.append(
            Row(
                SUITE,
                f"via_point_{name}",
                "taskspace",
                Timing.from_samples(wall),
                {
                    "seeds": len(firsts),
                    "rollouts_to_2cm": firsts,
                    "median_rollouts_to_2cm": median if np.isfinite(median) else None,
                    "final_via_error_m": [round(e, 4) for e in finals],
                },
                note="timing: wall time of one run (400 rollouts)",
            )
        )
    return rows


def scene_dmp() -> tuple[DiscreteDMP, DMPTaskTarget]:
    """The learned DMP and an online driver of a 3-D task (the planar arm's joints)."""
    t = np.linspace(0, 1, 201)
    s = t / t[-1]
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    Y = np.stack([0.3 * mj, 0.5 * np.sin(np.pi * t), -0.2 * mj], axis=1)
    dmp = DiscreteDMP.fit(t, Y, DMPOptions(num_basis=30))
    task = Task(JointConfiguration(Robot.load("planar_3link")), np.zeros(3))
    return dmp, DMPTaskTarget(dmp, task)


def _dmp_rows(quick: bool) -> list[Row]:
    dmp, driver = scene_dmp()
    repeat = 5 if quick else 30
    rollouts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        dmp.rollout(0.001, duration=1.0, yd0=np.zeros(3))
        rollouts.append(time.perf_counter() - t0)
    steps = []
    for _ in range(900):
        t0 = time.perf_counter()
        driver.step(0.001)
        steps.append(time.perf_counter() - t0)
    out, note = _run_inline_peer("movement_primitives", DMP_PEER, [str(repeat)])
    peer = "movement-primitives"
    rows = []
    for scene, ours, key in (
        ("dmp_step", steps, "step_s"),
        ("dmp_rollout_1000", rollouts, "rollout_s"),
    ):
        rows.append(Row(SUITE, scene, "taskspace", Timing.from_samples(ours), ratio_to=peer))
        theirs = Timing.from_samples(out[key]) if out else None
        rows.append(Row(SUITE, scene, peer, theirs, note=note))
    return rows


def run(quick: bool) -> list[Row]:
    """Run the suite; ``quick`` keeps it short (about a minute on a loaded machine)."""
    return (
        _env_rows(quick)
        + _panda_rows(quick)
        + _ppo_rows(quick)
        + _fvi_rows(quick)
        + _cma_rows(quick)
        + _via_point_rows(quick)
        + _dmp_rows(quick)
    )
