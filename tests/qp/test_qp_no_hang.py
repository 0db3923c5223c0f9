"""QPSolver guard rails: bounded solves, refused data, a relaxation that is solved, honest status.

References are independent of the solver under test: quadprog called directly (its own
Goldfarb-Idnani active set) on the problem or on the penalty formulation written out here.
"""

from __future__ import annotations

import numpy as np
import pytest
import quadprog

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.qp import INF, QPProblem, QPSolver, QPSolverOptions, QPStatus, RowBlock
from taskspace.qp.solver import MAX_QP_MAGNITUDE

pytestmark = [
    pytest.mark.filterwarnings("ignore:Converted matrix:UserWarning"),
    pytest.mark.filterwarnings("ignore:OSQP exited with status:UserWarning"),
]


def _quadprog(
    H: np.ndarray,
    g: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    G: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> np.ndarray:
    """``min 1/2 x'Hx + g'x`` s.t. ``A x = b``, ``lo <= G x <= hi`` (finite sides only)."""
    rows, rhs = [A], [b]
    finite_lo, finite_hi = lo > -INF, hi < INF
    rows += [G[finite_lo], -G[finite_hi]]
    rhs += [lo[finite_lo], -hi[finite_hi]]
    M = np.vstack(rows)
    return quadprog.solve_qp(H, -g, M.T, np.concatenate(rhs), meq=A.shape[0])[0]


def _ill_conditioned(scale: float, seed: int = 0) -> QPProblem:
    """12 variables, H eigenvalues 1e-8..1, g of size ``scale``, 3 equalities, 8 two-sided rows.

    proxsuite 0.8 alone needs ~10,000 iterations on it at ``scale = 1e10`` (the former
    1000 x 1000 limits let it run them; it converges to SOLVED eventually).
    """
    rng = np.random.default_rng(seed)
    n = 12
    M = rng.normal(size=(n, n))
    H = M @ M.T * 1e-3 + np.diag(np.logspace(-8, 0, n))
    g = rng.normal(size=n) * scale
    C = rng.normal(size=(8, n))
    A = rng.normal(size=(3, n))
    return QPProblem(
        H,
        g,
        A,
        rng.normal(size=3),
        C,
        -np.ones(8),
        np.ones(8),
        np.full(n, -INF),
        np.full(n, INF),
        eq_blocks=[RowBlock("tasks", 0, 3)],
        in_blocks=[RowBlock("limits", 0, 4), RowBlock("cones", 4, 8)],
    )


def test_proxsuite_run_is_bounded_and_never_reported_solved_at_its_limit() -> None:
    p = _ill_conditioned(1e10)
    options = QPSolverOptions(
        backend="proxsuite", fallbacks=(), try_unconstrained=False, relax_on_failure=False
    )
    result = QPSolver(options).solve(p)
    # at most max_iter outer x (max_iter_in + 1) iterations: 200 x 31 by default
    assert result.iterations <= options.max_iter * (options.max_iter_in + 1) <= 10_000
    assert result.status is not QPStatus.SOLVED or result.kkt.within(1e-9, 1e-9)
    if result.status is QPStatus.MAX_ITERATIONS:
        assert not result.success


def test_default_pipeline_still_exact_on_the_ill_conditioned_problem() -> None:
    p = _ill_conditioned(1e10)
    result = QPSolver().solve(p)
    assert result.success and result.status is QPStatus.SOLVED
    assert result.kkt.within(1e-9, 1e-9)
    x_ref = _quadprog(p.H, p.g, p.A, p.b, p.C, p.l, p.u)
    # the optimum is of size |H^-1 g| ~ 1e10: compare relatively
    assert np.abs(result.x - x_ref).max() <= 1e-6 * np.abs(x_ref).max()


@pytest.mark.parametrize("name", ["H", "g", "A", "b", "C", "l", "u", "lb", "ub"])
def test_nan_data_is_refused_naming_the_array_and_block(name: str) -> None:
    p = _ill_conditioned(1.0)
    arr = getattr(p, name)
    bad = arr.copy()
    row = 5 if name in ("C", "l", "u") else 1
    bad[row] = np.nan
    setattr(p, name, bad)
    with pytest.raises(NotFiniteError) as info:
        QPSolver().solve(p)
    message = str(info.value)
    assert f"QP {name} " in message and f"[{row}]" in message
    if name in ("C", "l", "u"):
        assert "cones" in message  # row 5 is in the block "cones"
    if name in ("A", "b"):
        assert "tasks" in message


def test_infinite_matrix_entry_is_refused() -> None:
    p = _ill_conditioned(1.0)
    p.C[2, 3] = np.inf
    with pytest.raises(NotFiniteError, match=r"QP C rows \[2\].*limits"):
        QPSolver().solve(p)


def test_infinite_bounds_mean_no_bound() -> None:
    p = _ill_conditioned(1.0)
    p.u[:] = np.inf
    p.lb[:] = -np.inf
    result = QPSolver().solve(p)
    assert result.success
    x_ref = _quadprog(p.H, p.g, p.A, p.b, p.C, p.l, np.full(8, INF))
    np.testing.assert_allclose(result.x, x_ref, atol=1e-6 * max(1.0, np.abs(x_ref).max()))


def test_absurd_magnitudes_are_refused_before_any_backend() -> None:
    # a diverged state's QP (bolt after the rollout blew up had |g| ~ 1e41): refused at once
    p = _ill_conditioned(1e40)
    with pytest.raises(InvalidInputError, match="diverged") as info:
        QPSolver().solve(p)
    assert "QP g" in str(info.value)
    assert not isinstance(info.value, NotFiniteError)
    assert MAX_QP_MAGNITUDE < 1e40


def test_unconstrained_minimizer_of_large_but_valid_data_is_kept() -> None:
    # the check guards the backends: an exact unconstrained answer is still given
    H = 1e20 * np.eye(3)
    g = np.array([1e35, 0.0, 0.0])
    p = QPProblem.unconstrained(H, g)
    result = QPSolver().solve(p)
    assert result.status is QPStatus.UNCONSTRAINED
    np.testing.assert_allclose(result.x, [-1e15, 0.0, 0.0])


@pytest.mark.parametrize(
    "field, value",
    [
        ("max_iter", 0),
        ("max_iter", 10**9),
        ("max_iter", 2.5),
        ("max_iter", True),
        ("max_iter_in", -1),
        ("max_polish_iter", 0),
        ("eps_abs", float("nan")),
        ("relaxation_weight", 0.0),
        ("time_limit", float("nan")),
        ("time_limit", 0.0),
        ("time_limit", -1.0),
    ],
)
def test_options_that_would_hang_or_do_nothing_are_refused(field: str, value: object) -> None:
    with pytest.raises(InvalidInputError, match=field):
        QPSolverOptions(**{field: value})  # type: ignore[arg-type]


def test_time_limit_skips_the_remaining_stages() -> None:
    p = _ill_conditioned(1e10)
    options = QPSolverOptions(backend="proxsuite", fallbacks=("daqp",), time_limit=1e-12)
    result = QPSolver(options).solve(p)
    # the budget was spent by the first backend: no daqp, no relaxation
    assert result.backend.startswith("proxsuite")
    assert result.status is not QPStatus.RELAXED
    assert not result.success or result.kkt.within(1e-9, 1e-9)


def _penalty_reference(p: QPProblem, w: float) -> np.ndarray:
    """The least-violating point ``min f(x) + w/2 |s|^2`` written out with plain slacks
    and solved by quadprog (independent of taskspace's scaled formulation)."""
    n, m_eq, m_in = p.n, p.n_eq, p.n_in
    box = np.flatnonzero((p.lb > -INF) | (p.ub < INF))
    k = box.size
    N = n + m_eq + m_in + k
    H = np.zeros((N, N))
    H[:n, :n] = p.H
    H[n:, n:] = w * np.eye(N - n)
    g = np.concatenate([p.g, np.zeros(N - n)])
    A = np.hstack([p.A, -np.eye(m_eq), np.zeros((m_eq, m_in + k))])
    E = np.eye(n)[box]
    Z = np.zeros
    G = np.vstack(
        [
            np.hstack([p.C, Z((m_in, m_eq)), np.eye(m_in), Z((m_in, k))]),  # C x + s >= l
            np.hstack([-p.C, Z((m_in, m_eq)), np.eye(m_in), Z((m_in, k))]),  # -C x + s >= -u
            np.hstack([E, Z((k, m_eq + m_in)), np.eye(k)]),
            np.hstack([-E, Z((k, m_eq + m_in)), np.eye(k)]),
            np.hstack([Z((m_in + k, n + m_eq)), np.eye(m_in + k)]),  # s >= 0
        ]
    )
    lo = np.concatenate([p.l, -p.u, p.lb[box], -p.ub[box], np.zeros(m_in + k)])
    keep = lo > -INF
    return _quadprog(H, g, A, p.b, G[keep], lo[keep], np.full(keep.sum(), INF))[:n]


def _conflicting(seed: int = 1) -> QPProblem:
    """An ill-conditioned QP (H eigenvalues 1e-8..1) whose equalities leave the box."""
    rng = np.random.default_rng(seed)
    n = 10
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    H = Q @ np.diag(np.logspace(-8, 0, n)) @ Q.T
    A = rng.normal(size=(4, n))
    C = rng.normal(size=(6, n))
    return QPProblem(
        H,
        rng.normal(size=n),
        A,
        20.0 * np.ones(4),
        C,
        -np.ones(6),
        np.ones(6),
        -0.5 * np.ones(n),
        0.5 * np.ones(n),
        eq_blocks=[RowBlock("contacts", 0, 4)],
        in_blocks=[RowBlock("torque limits", 0, 6)],
        box_blocks=[RowBlock("joint limits", 0, n)],
    )


def test_relaxation_of_an_ill_conditioned_infeasible_qp_is_the_penalty_optimum() -> None:
    # With the plain penalty w |s|^2 the relaxed Hessian was 1e14-conditioned: daqp's
    # Cholesky failed and proxsuite ran to its limit (seconds on an inverse-dynamics QP).
    p = _conflicting()
    w = 1e6
    result = QPSolver(QPSolverOptions(relaxation_weight=w)).solve(p)
    assert result.status is QPStatus.RELAXED and not result.success
    assert {"contacts", "joint limits"} <= set(result.culprits)
    x_ref = _penalty_reference(p, w)
    np.testing.assert_allclose(result.x, x_ref, atol=1e-6 * max(1.0, np.abs(x_ref).max()))
    assert result.iterations < 1000


def test_relaxed_status_requires_a_solved_relaxation() -> None:
    # a relaxation stopped at its iteration limit is FAILED, not RELAXED
    p = _conflicting()
    options = QPSolverOptions(
        backend="proxsuite", fallbacks=(), max_iter=1, max_iter_in=1, max_polish_iter=1
    )
    solver = QPSolver(options)
    # the relaxation uses daqp when available: make it unavailable to this solve
    import taskspace.qp.solver as module

    original = module.available_backends
    module.available_backends = lambda: ["proxsuite"]  # type: ignore[assignment]
    try:
        result = solver.solve(p)
    finally:
        module.available_backends = original  # type: ignore[assignment]
    assert result.status is QPStatus.FAILED
    assert not result.success


def test_ill_conditioned_ik_step_is_the_optimum_not_only_small_residuals() -> None:
    """G1 IK step whose floating base only the 1e-6 damping holds (posture skips the base).

    cond(H) ~ 1e6: proxsuite stopped at dual residuals ~1.6e-9 (within 1e-9 + 1e-9 * scale,
    so ``SOLVED``) with steps 1e-3 from the optimum. The default pipeline and proxsuite alone
    now return the optimum to 1e-8; the reference is quadprog called directly.
    """
    from taskspace import features as F
    from taskspace.constraints import JointPositionLimits, JointVelocityLimits
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.tasks import Task
    from tests.conftest import load_robot

    robot = load_robot("g1")
    frame = "left_rubber_hand"
    rng = np.random.default_rng(0)
    task = Task(F.Position(robot, frame), np.zeros(3), gain=1.0)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    assert posture.dim == robot.nv - 6  # the base is not regularized by the posture
    ik = DifferentialIK(
        robot,
        [task, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=False),
    )
    bare = QPSolver(
        QPSolverOptions(
            backend="proxsuite", fallbacks=(), relax_on_failure=False, try_unconstrained=False
        )
    )
    default = QPSolver()
    for _ in range(4):
        state = robot.state(robot.random_configuration(rng))
        task.set_target(robot.frame_placement(robot.random_configuration(rng), frame).translation)
        p = ik.build(state, 0.02)
        G = np.vstack([p.C, np.eye(p.n)])
        x_ref = _quadprog(
            p.H, p.g, p.A, p.b, G, np.concatenate([p.l, p.lb]), np.concatenate([p.u, p.ub])
        )
        assert np.linalg.cond(p.H) > 1e5
        for solver in (bare, default):
            r = solver.solve(p)
            assert r.status is QPStatus.SOLVED and r.kkt.within(1e-9, 1e-9)
            np.testing.assert_allclose(r.x, x_ref, atol=1e-8)
