"""Closure and quality against analytic cases, brute force and Pinocchio."""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InfeasibleError, InvalidInputError
from taskspace.grasping import (
    ContactType,
    GraspContact,
    balance_forces,
    closure_hull,
    closure_lp,
    epsilon_l1,
    epsilon_linf,
    force_closure,
    form_closure,
    grasp_matrix,
    grasp_quality,
    minimal_closure_subset,
    primitive_wrenches,
    task_wrench_scale,
)

PLANAR = [0, 1, 5]  # fx, fy, tau_z


def planar_wrenches(contacts: list[GraspContact], rho: float) -> tuple[np.ndarray, list[int]]:
    """Planar grasps in the xy-plane: with 4 edges two lie in the plane, the exact 2-D cone."""
    W, owner = primitive_wrenches(contacts, edges=4, torque_scale=rho)
    keep = np.abs(W[:, 2]) < 1e-12  # the edges with no z component
    return W[keep][:, PLANAR], [o for o, k in zip(owner, keep) if k]


def contact(p, n, **kw) -> GraspContact:
    return GraspContact(np.asarray(p, float), np.asarray(n, float), **kw)


def support_min(W: np.ndarray, owner: list[int] | None, n_dirs: int = 200_000) -> float:
    """min over unit directions of the support function of the GWS (brute force)."""
    rng = np.random.default_rng(0)
    u = rng.standard_normal((n_dirs, W.shape[1]))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    proj = u @ W.T
    if owner is None:
        h = proj.max(axis=1)
    else:
        o = np.asarray(owner)
        h = sum(np.maximum(0.0, proj[:, o == i].max(axis=1)) for i in sorted(set(owner)))
    return float(h.min())


@pytest.mark.parametrize("mu", [0.2, 0.5, 1.0])
def test_two_opposed_fingers_planar_epsilon_is_analytic(mu: float) -> None:
    r = 0.05
    grasp = [contact([r, 0, 0], [-1, 0, 0], mu=mu), contact([-r, 0, 0], [1, 0, 0], mu=mu)]
    W, owner = planar_wrenches(grasp, rho=r)
    expected = mu / np.sqrt(mu**2 + 2)  # the tetrahedron's inscribed radius
    assert epsilon_l1(W) == pytest.approx(expected, rel=1e-9)
    assert closure_lp(W).closure and closure_hull(W).closure
    assert closure_hull(W).margin == pytest.approx(expected, rel=1e-9)
    # L-infinity: against the support function, brute force over directions.
    linf = epsilon_linf(W, owner)
    assert linf >= expected - 1e-12
    # No direction has a smaller support than epsilon (the ball is inside), and sampled
    # directions come close to it (the ball touches).
    for owners, eps in ((owner, linf), (None, expected)):
        sampled = support_min(W, owners)
        assert eps - 1e-12 <= sampled <= eps + 1e-2


def test_epsilon_grows_with_friction_and_ignores_contact_order() -> None:
    rng = np.random.default_rng(1)
    previous = 0.0
    for mu in (0.1, 0.3, 0.6, 1.2):
        angles = 2 * np.pi * np.arange(3) / 3
        grasp = [
            contact([np.cos(a), np.sin(a), 0.0], [-np.cos(a), -np.sin(a), 0.0], mu=mu)
            for a in angles
        ]
        q = grasp_quality(grasp, edges=4)
        assert force_closure(grasp).closure  # three fingers at 120 deg on a sphere
        assert q.epsilon_l1 > previous
        previous = q.epsilon_l1
        shuffled = [grasp[i] for i in rng.permutation(3)]
        q2 = grasp_quality(shuffled, edges=4)
        assert q2.epsilon_l1 == pytest.approx(q.epsilon_l1, rel=1e-9)
        assert q2.epsilon_linf == pytest.approx(q.epsilon_linf, rel=1e-9)
        assert q2.volume == pytest.approx(q.volume, rel=1e-9)
        assert q.epsilon_linf >= q.epsilon_l1 - 1e-12  # the L-inf GWS contains the L1 one


def test_three_fingers_on_a_disk_at_120_deg_planar() -> None:
    """Planar disk, three frictionless fingers at 120 deg: no closure (they cannot resist a
    torque); with friction: closure, with the epsilon of the brute-force support function."""
    angles = 2 * np.pi * np.arange(3) / 3
    for mu, closed in ((0.0, False), (0.4, True)):
        grasp = [
            contact([np.cos(a), np.sin(a), 0], [-np.cos(a), -np.sin(a), 0], mu=mu) for a in angles
        ]
        W, _ = planar_wrenches(grasp, rho=1.0)
        lp, hull = closure_lp(W), closure_hull(W)
        assert lp.closure is closed and hull.closure is closed
        if closed:
            assert hull.margin - 1e-12 <= support_min(W, None) <= hull.margin + 1e-2
        else:  # the certificate: a pure torque that no contact can produce
            c = lp.certificate
            assert np.all(W @ c >= -1e-9)
            assert abs(c[2]) == pytest.approx(1.0, abs=1e-6)


def test_frictionless_square_form_closure() -> None:
    """Four frictionless fingers on a square: at the side midpoints no form closure (a torque
    is free); with opposite sides' contacts offset in opposite directions, form closure."""
    sides = [
        ([1, 0, 0], [-1, 0, 0], [0, -1, 0]),
        ([0, 1, 0], [0, -1, 0], [-1, 0, 0]),
        ([-1, 0, 0], [1, 0, 0], [0, 1, 0]),
        ([0, -1, 0], [0, 1, 0], [1, 0, 0]),
    ]
    for offset, closed in ((0.0, False), (0.5, True)):
        grasp = [
            contact(np.array(p) + offset * np.array(t), n, type=ContactType.FRICTIONLESS)
            for p, n, t in sides
        ]
        W, _ = primitive_wrenches(grasp, torque_scale=1.0)
        W = W[:, PLANAR]
        assert closure_lp(W).closure is closed
        assert closure_hull(W).closure is closed
        if not closed:
            c = closure_lp(W).certificate
            assert np.all(W @ c >= -1e-9)


def test_two_antipodal_soft_fingers_3d_and_certificate_of_point_contacts() -> None:
    r = 0.04
    soft = [
        contact([r, 0, 0], [-1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.5, torsion=0.01),
        contact([-r, 0, 0], [1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.5, torsion=0.01),
    ]
    assert force_closure(soft).closure and force_closure(soft, method="hull").closure
    point = [GraspContact(c.position, c.normal, mu=0.5) for c in soft]
    result = force_closure(point)
    assert not result.closure
    W, _ = primitive_wrenches(point)
    c = result.certificate
    assert np.all(W @ c >= -1e-9)  # every wrench the grasp can apply is on one side
    assert abs(c[3]) == pytest.approx(1.0, abs=1e-6)  # the free torque about the x axis
    assert not form_closure(soft).closure


@pytest.mark.parametrize("factor, expected", [(0.97, True), (1.03, False)])
def test_exact_cone_decides_antipodal_condition(factor: float, expected: bool) -> None:
    """Two soft fingers whose normals make an angle alpha with the line joining them are in
    closure with circular cones exactly when alpha < atan(mu)."""
    mu = 0.4
    alpha = np.arctan(mu) * factor
    tilt = [np.cos(alpha), np.sin(alpha) * np.cos(0.3), np.sin(alpha) * np.sin(0.3)]
    grasp = [
        contact([0.05, 0, 0], -np.array(tilt), type=ContactType.SOFT_FINGER, mu=mu, torsion=0.01),
        contact([-0.05, 0, 0], [1, 0, 0], type=ContactType.SOFT_FINGER, mu=mu, torsion=0.01),
    ]
    assert force_closure(grasp, edges=4, exact_cone=True).closure is expected


def test_lp_and_hull_agree_on_random_grasps() -> None:
    rng = np.random.default_rng(7)
    seen = {True: 0, False: 0}
    for _ in range(60):
        k = int(rng.integers(2, 5))
        normals = rng.standard_normal((k, 3))
        positions = -normals / np.linalg.norm(normals, axis=1, keepdims=True) * 0.05
        mu = float(rng.uniform(0.1, 0.9))
        grasp = [contact(p, n, mu=mu) for p, n in zip(positions, normals)]
        lp = force_closure(grasp, method="lp")
        hull = force_closure(grasp, method="hull")
        assert lp.closure == hull.closure
        seen[lp.closure] += 1
    assert seen[True] > 5 and seen[False] > 5


def test_grasp_matrix_transpose_maps_object_twist_to_contact_velocities() -> None:
    """Finite differences of the contact points of a moving rigid object."""
    rng = np.random.default_rng(3)
    center = np.array([0.01, -0.02, 0.03])
    grasp = [
        contact(rng.standard_normal(3) * 0.05, rng.standard_normal(3), mu=0.3),
        contact(
            rng.standard_normal(3) * 0.05,
            rng.standard_normal(3),
            type=ContactType.SOFT_FINGER,
            torsion=0.01,
        ),
        contact(
            rng.standard_normal(3) * 0.05, rng.standard_normal(3), type=ContactType.FRICTIONLESS
        ),
    ]
    G = grasp_matrix(grasp, center)
    v, w = rng.standard_normal(3), rng.standard_normal(3)
    h = 1e-6
    rows = []
    for c in grasp:

        def point(t: float, c: GraspContact = c) -> np.ndarray:
            return center + t * v + pin.exp3(t * w) @ (c.position - center)

        velocity = (point(h) - point(-h)) / (2 * h)
        local = np.hstack([c.rotation.T @ velocity, c.rotation.T @ w])
        sel = {
            ContactType.FRICTIONLESS: [2],
            ContactType.POINT_FRICTION: [0, 1, 2],
            ContactType.SOFT_FINGER: [0, 1, 2, 5],
        }[c.type]
        rows.append(local[sel])
    assert np.allclose(G.T @ np.hstack([v, w]), np.hstack(rows), atol=1e-8)


def brute_force_balance(W: np.ndarray, F: np.ndarray, w_ext: np.ndarray, eps: float) -> np.ndarray:
    """min |F lam|^2 + eps |lam|^2, W^T lam = -w_ext, lam >= 0, by enumerating active sets."""
    k = W.shape[0]
    H = F.T @ F + eps * np.eye(k)
    best, best_val = None, np.inf
    for size in range(1, k + 1):
        for free in itertools.combinations(range(k), size):
            idx = list(free)
            A = W[idx].T
            kkt = np.block([[H[np.ix_(idx, idx)], A.T], [A, np.zeros((6, 6))]])
            rhs = np.hstack([np.zeros(size), -w_ext])
            sol = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
            lam = np.zeros(k)
            lam[idx] = sol[:size]
            if np.min(lam) < -1e-10 or np.linalg.norm(W.T @ lam + w_ext) > 1e-8:
                continue
            val = lam @ H @ lam
            if val < best_val - 1e-15:
                best, best_val = lam, val
    assert best is not None
    return best


def test_balance_forces_against_brute_force() -> None:
    r = 0.05
    grasp = [
        contact([r, 0, 0], [-1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.6, torsion=0.02),
        contact([-r, 0, 0], [1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.6, torsion=0.02),
    ]
    w_ext = np.array([0.0, 0.0, -2.0, 0.01, 0.0, 0.0])  # weight of a 0.2 kg object + a twist
    result = balance_forces(grasp, w_ext, edges=4, regularization=1e-6)
    W, _ = primitive_wrenches(grasp, edges=4, torque_scale=1.0)
    from taskspace.grasping.contact_forces import edge_matrix

    E, _ = edge_matrix(grasp, 4)
    F = E.reshape(2, 4, -1)[:, :3, :].reshape(6, -1)
    lam = brute_force_balance(W, F, w_ext, 1e-6)
    assert np.allclose(result.coefficients, lam, atol=1e-6)
    total = result.forces.sum(axis=0)
    assert np.allclose(total, -w_ext[:3], atol=1e-8)
    for f, c in zip(result.forces, grasp):  # inside the friction cones
        fn = f @ c.normal
        assert fn > 0 and np.linalg.norm(f - fn * c.normal) <= c.mu * fn + 1e-9
    with pytest.raises(InfeasibleError):
        point = [GraspContact(c.position, c.normal, mu=0.6) for c in grasp]
        balance_forces(point, np.array([0, 0, 0, 1.0, 0, 0]), edges=4)


def test_task_wrench_scale_and_pruning() -> None:
    r = 0.05
    grasp = [
        contact([r, 0, 0], [-1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.5, torsion=0.01),
        contact([0, r, 0.01], [0, -1, 0], mu=0.5),
        contact([-r, 0, 0], [1, 0, 0], type=ContactType.SOFT_FINGER, mu=0.5, torsion=0.01),
    ]
    assert minimal_closure_subset(grasp) == [0, 2]
    W, _ = primitive_wrenches(grasp)
    gravity = np.array([[0, 0, -1.0, 0, 0, 0]])
    k = task_wrench_scale(W, gravity)
    # k g is on the boundary of the GWS: inside at 0.999 k, outside at 1.001 k (LP membership)
    from scipy.optimize import linprog

    def inside(w: np.ndarray) -> bool:
        n = W.shape[0]
        res = linprog(
            np.zeros(n),
            A_eq=np.vstack([W.T, np.ones(n)]),
            b_eq=np.hstack([w, 1]),
            bounds=[(0, None)] * n,
            method="highs",
        )
        return res.status == 0

    assert inside(0.999 * k * gravity[0]) and not inside(1.001 * k * gravity[0])


def test_bad_input() -> None:
    with pytest.raises(InvalidInputError):
        GraspContact(np.zeros(3), np.zeros(3))
    with pytest.raises(InvalidInputError):
        GraspContact(np.zeros(3), np.array([0, 0, 1.0]), mu=float("nan"))
    with pytest.raises(InvalidInputError, match="valid methods are: hull, lp"):
        force_closure([contact([0, 0, 0], [0, 0, 1])], method="qhull")
    with pytest.raises(InvalidInputError):
        force_closure([])


def test_epsilon_matches_the_one_qp_per_facet_reference() -> None:
    from benchmarks.ferrari_canny_reference import epsilon_reference

    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(12):
        k = int(rng.integers(3, 6))
        normals = rng.standard_normal((k, 3))
        positions = -normals / np.linalg.norm(normals, axis=1, keepdims=True) * 0.05
        grasp = [contact(p, n, mu=0.6) for p, n in zip(positions, normals)]
        W, _ = primitive_wrenches(grasp, edges=6)
        ours = epsilon_l1(W)
        assert ours == pytest.approx(epsilon_reference(W), abs=1e-7)
        checked += ours > 0
    assert checked >= 4
