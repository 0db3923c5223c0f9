"""qpmpc peer for the locomotion suite (runs in .venv-peers/qpmpc).

The ZMP MPC of the same walk as taskspace's ``ZmpMpc`` (``mpc_step`` scene), posed in qpmpc's
idiom: the cart-table model of both axes (state ``(c, cdot, cddot)`` per axis, jerk input, the
suite's own discrete ``A``, ``B``) as one ``qpmpc.MPCProblem`` with the ZMP kept in the support
polygon of every predicted sample (``C_k x_k <= e_k``, the suite's halfspaces), built by
``qpmpc.MPCQP`` and solved by ProxQP through qpsolvers (``solve_mpc`` split in its two calls so
that the QP time can be read apart), in closed loop over the walk.

Cost (Wieber 2006): ``sum_k Q |z_k - z_ref_k|^2 + R |jerk_k|^2`` with the suite's ``Q``
(``error_weight``) and ``R`` (``input_weight``). qpmpc weighs the whole state with one scalar,
so its state is written in coordinates ``y = (z, eps cdot, eps cddot)`` per axis (``z`` the
ZMP, ``eps = 1e-3``): the stage cost is the ZMP error plus ``1e-6`` of the CoM velocity and
acceleration. ``nb_timesteps = N + 1`` so that the costed and constrained states are the same
predicted samples ``t_{k+1} .. t_{k+N}`` as taskspace's (qpmpc's ``x_0`` is the current state).

Usage: ``python qpmpc_zmp.py INPUT.json`` with ``dt, com_height, gravity, horizon,
error_weight, input_weight, A (3x3), B (3), reference (T x 2)`` and ``halfspaces``: one
``[A_k, b_k]`` per sample ``0 .. T + N`` (held after the walk). Prints one JSON line with the
per-step times ``step_us`` (MPCQP + QP) and ``qp_us``, the RMS and max ZMP tracking errors
[mm] (taskspace's definition: the distance between the model's ZMP and the reference at every
sample), the worst polygon violation [mm] and ``success``.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
import qpmpc
from qpmpc import MPCProblem
from qpmpc.mpc_qp import MPCQP
from qpsolvers import solve_problem

EPS = 1e-3


def main() -> None:
    with open(sys.argv[1], encoding="utf-8") as f:
        data = json.load(f)
    dt, h, g, N = data["dt"], data["com_height"], data["gravity"], data["horizon"]
    A3, B3 = np.array(data["A"]), np.array(data["B"]).reshape(3)
    ref = np.array(data["reference"])
    halfspaces = [(np.array(a), np.array(b)) for a, b in data["halfspaces"]]
    T = ref.shape[0]
    padded = np.vstack([ref, np.repeat(ref[-1:], N + 2, axis=0)])

    # y = S x per axis, state order (x axis, y axis)
    S3 = np.array([[1.0, 0.0, -h / g], [0.0, EPS, 0.0], [0.0, 0.0, EPS]])
    S = np.kron(np.eye(2), S3)
    A = S @ np.kron(np.eye(2), A3) @ np.linalg.inv(S)
    B = S @ np.kron(np.eye(2), B3.reshape(3, 1))
    steps = N + 1

    def constraint(j: int) -> tuple[np.ndarray, np.ndarray]:
        Ah, bh = halfspaces[min(j, len(halfspaces) - 1)]
        C = np.zeros((Ah.shape[0], 6))
        C[:, 0], C[:, 3] = Ah[:, 0], Ah[:, 1]  # the ZMP coordinates of y
        return C, bh

    trivial = (np.zeros((1, 6)), np.ones(1))  # x_0 is given: no row on it
    problem = MPCProblem(
        transition_state_matrix=A,
        transition_input_matrix=B,
        ineq_state_matrix=[trivial[0]] * steps,
        ineq_input_matrix=None,
        ineq_vector=[trivial[1]] * steps,
        nb_timesteps=steps,
        terminal_cost_weight=None,
        stage_state_cost_weight=data["error_weight"],
        stage_input_cost_weight=data["input_weight"],
        initial_state=np.zeros(6),
        target_states=np.zeros(6 * steps),
    )

    x = np.zeros((3, 2))
    x[0] = ref[0]
    zmp = np.empty((T, 2))
    step_us, qp_us = np.empty(T), np.empty(T)
    violation, success = 0.0, True
    for k in range(T):
        zmp[k] = x[0] - h / g * x[2]
        Ah, bh = halfspaces[min(k, len(halfspaces) - 1)]
        violation = max(violation, float(np.max(Ah @ zmp[k] - bh)))
        t0 = time.perf_counter()
        problem.update_initial_state(S @ x.T.ravel())
        targets = np.zeros((steps, 6))
        targets[:, 0], targets[:, 3] = padded[k : k + steps, 0], padded[k : k + steps, 1]
        problem.update_target_states(targets)
        rows = [trivial] + [constraint(k + j) for j in range(1, steps)]
        problem.ineq_state_matrix = [c for c, _ in rows]
        problem.ineq_vector = [e for _, e in rows]
        mpc_qp = MPCQP(problem)
        t1 = time.perf_counter()
        sol = solve_problem(mpc_qp.problem, solver="proxqp", eps_abs=1e-9, eps_rel=0.0)
        t2 = time.perf_counter()
        plan = qpmpc.Plan(problem, sol)
        step_us[k], qp_us[k] = (t2 - t0) * 1e6, (t2 - t1) * 1e6
        if plan.is_empty or not sol.found:
            success = False
            break
        u = plan.first_input
        x = A3 @ x + np.outer(B3, u)
    err = np.linalg.norm(zmp[: k + 1] - ref[: k + 1], axis=1)
    print(
        json.dumps(
            {
                "step_us": step_us[: k + 1].tolist(),
                "qp_us": qp_us[: k + 1].tolist(),
                "rms_zmp_error_mm": 1000 * float(np.sqrt(np.mean(err**2))),
                "max_zmp_error_mm": 1000 * float(err.max()),
                "max_polygon_violation_mm": 1000 * max(violation, 0.0),
                "success": success,
                "samples": int(k + 1),
                "qpmpc": getattr(qpmpc, "__version__", "?"),
                "dt": dt,
            }
        )
    )


if __name__ == "__main__":
    main()
