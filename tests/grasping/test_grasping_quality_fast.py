"""The fast L1 epsilon (certified unmerged hull, batches) against independent references.

References: facet enumeration without qhull (every d-subset of the wrenches whose plane
supports them all), the textbook definition (one QP per facet of the merged hull, as Dex-Net
computes it), closed forms of planar grasps, and the closure LP.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import quadprog
from scipy.spatial import ConvexHull

import taskspace.grasping.epsilon as eps_module
from taskspace.errors import InvalidInputError
from taskspace.grasping import (
    ContactType,
    GraspContact,
    closure_lp,
    epsilon_l1,
    epsilon_l1_batch,
    epsilon_l1_fast,
    grasp_epsilon_batch,
    primitive_wrenches,
    primitive_wrenches_batch,
)

PLANAR = [0, 1, 5]  # fx, fy, tau_z


def enumerated_epsilon(W: np.ndarray) -> float:
    """min offset over every supporting plane through d affinely independent wrenches."""
    k, d = W.shape
    scale = np.abs(W).max()
    best = np.inf
    for subset in itertools.combinations(range(k), d):
        A = np.hstack([W[list(subset)], -np.ones((d, 1))])  # a^T w - b = 0
        _, s, vt = np.linalg.svd(A)
        if s[-1] < 1e-9 * s[0]:
            continue  # not affinely independent
        a, b = vt[-1, :-1], vt[-1, -1]
        norm = np.linalg.norm(a)
        a, b = a / norm, b / norm
        side = W @ a - b
        if side.max() <= 1e-12 * scale:
            best = min(best, b)
        elif side.min() >= -1e-12 * scale:
            best = min(best, -b)
    return float(best) if best > 1e-9 * scale else 0.0


def textbook_epsilon(W: np.ndarray) -> float:
    """One QP per facet of the (merged, qhull default) hull: nearest point of each simplex."""
    hull = ConvexHull(W)
    if np.any(hull.equations[:, -1] >= -1e-9 * np.abs(W).max()):
        return 0.0
    best = np.inf
    for simplex in hull.simplices:
        V = W[simplex]
        k = len(simplex)
        G = V @ V.T + 1e-14 * np.eye(k)
        C = np.hstack([np.ones((k, 1)), np.eye(k)])
        a = quadprog.solve_qp(G, np.zeros(k), C, np.hstack([1.0, np.zeros(k)]), meq=1)[0]
        best = min(
            best, float(np.linalg.norm(V.T @ np.clip(a, 0, None) / np.clip(a, 0, None).sum()))
        )
    return best


def random_grasp(rng: np.random.Generator, k: int, **kw: object) -> list[GraspContact]:
    normals = rng.standard_normal((k, 3))
    positions = -normals / np.linalg.norm(normals, axis=1, keepdims=True) * 0.05
    positions += 0.01 * rng.standard_normal((k, 3))
    return [GraspContact(p, n, **kw) for p, n in zip(positions, normals)]  # type: ignore[arg-type]


def contact(p: list[float], n: list[float], **kw: object) -> GraspContact:
    return GraspContact(np.asarray(p, float), np.asarray(n, float), **kw)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("k", "edges", "kind"),
    [
        (3, 4, ContactType.POINT_FRICTION),
        (4, 3, ContactType.POINT_FRICTION),
        (2, 4, ContactType.SOFT_FINGER),
    ],
)
def test_equals_facet_enumeration_without_qhull(k: int, edges: int, kind: ContactType) -> None:
    rng = np.random.default_rng(k * 10 + edges)
    inside = outside = 0
    for _ in range(60):
        grasp = random_grasp(rng, k, type=kind, mu=1.0, torsion=0.01)
        if k == 2:  # nearly antipodal soft fingers
            grasp[1] = GraspContact(
                -grasp[0].position + 0.005 * rng.standard_normal(3),
                -grasp[0].normal + 0.3 * rng.standard_normal(3),
                type=kind,
                mu=1.0,
                torsion=0.01,
            )
        W, _ = primitive_wrenches(grasp, edges=edges)
        expected = enumerated_epsilon(W)
        assert epsilon_l1_fast(W) == pytest.approx(expected, rel=1e-9, abs=1e-14)
        inside += expected > 0
        outside += expected == 0
        if inside >= 3 and outside >= 1:
            break
    assert inside >= 3 and outside >= 1


@pytest.mark.parametrize("k", [3, 5])
def test_equals_textbook_one_qp_per_facet_with_8_edges(k: int) -> None:
    rng = np.random.default_rng(k)
    inside = 0
    for _ in range(20):
        W, _ = primitive_wrenches(random_grasp(rng, k, mu=0.8), edges=8)
        expected = textbook_epsilon(W)
        assert epsilon_l1(W) == pytest.approx(expected, rel=1e-9, abs=1e-14)
        inside += expected > 0
        if inside >= 3:
            break
    assert inside >= 3


def planar(grasp: list[GraspContact], rho: float) -> np.ndarray:
    """(fx, fy, tau_z / rho) of the in-plane edges: with 4 edges, the exact planar cone."""
    W, _ = primitive_wrenches(grasp, edges=4, torque_scale=rho)
    return W[np.abs(W[:, 2]) < 1e-12][:, PLANAR]


@pytest.mark.parametrize("mu", [0.2, 0.5, 1.0])
def test_two_opposed_fingers_analytic(mu: float) -> None:
    r = 0.05
    grasp = [contact([r, 0, 0], [-1, 0, 0], mu=mu), contact([-r, 0, 0], [1, 0, 0], mu=mu)]
    # The four wrenches (+-1, +-mu, +-mu) span a tetrahedron of inradius mu / sqrt(mu^2 + 2).
    assert epsilon_l1_fast(planar(grasp, r)) == pytest.approx(mu / np.sqrt(mu**2 + 2), rel=1e-9)


@pytest.mark.parametrize("mu", [0.1, 0.4, 1.5])
def test_three_fingers_on_a_disk_at_120_deg_analytic(mu: float) -> None:
    r = 0.04
    angles = 2 * np.pi * np.arange(3) / 3
    grasp = [
        contact([r * np.cos(a), r * np.sin(a), 0], [-np.cos(a), -np.sin(a), 0], mu=mu)
        for a in angles
    ]
    # With rho = r the wrenches are (s u(a + pi -+ alpha), +-mu), s = sqrt(1 + mu^2),
    # alpha = atan(mu): two triangles at heights +-mu twisted by 2 alpha. Top and bottom
    # facets are at distance mu; a side facet through two top vertices and one bottom vertex
    # (or the mirror) is at distance |n . p| / |n| for its normal n = (q - p) x (t - p).
    s, alpha = np.sqrt(1 + mu**2), np.arctan(mu)

    def u(t: float) -> np.ndarray:
        return np.array([np.cos(t), np.sin(t)])

    top = [np.hstack([s * u(a + np.pi - alpha), mu]) for a in angles]
    bottom = [np.hstack([s * u(a + np.pi + alpha), -mu]) for a in angles]
    points = np.array(top + bottom)
    distances = [mu]
    for p, q, t in itertools.combinations(points, 3):
        n = np.cross(q - p, t - p)
        side = (points - p) @ n
        if np.linalg.norm(n) > 1e-12 and (side.max() <= 1e-12 or side.min() >= -1e-12):
            distances.append(abs(n @ p) / np.linalg.norm(n))
    W = planar(grasp, r)
    assert np.allclose(np.sort(np.abs(W).ravel()), np.sort(np.abs(points).ravel()))
    assert epsilon_l1_fast(W) == pytest.approx(min(distances), rel=1e-9)
    assert epsilon_l1_fast(W) == pytest.approx(enumerated_epsilon(W), rel=1e-9)


def test_batch_equals_one_by_one_and_primitive_wrenches() -> None:
    rng = np.random.default_rng(3)
    for k, torsion in ((3, 0.0), (5, 0.0), (2, 0.01)):
        positions = 0.05 * rng.standard_normal((12, k, 3))
        normals = -positions + 0.02 * rng.standard_normal((12, k, 3))
        center = np.array([0.001, -0.002, 0.003])
        kind = ContactType.SOFT_FINGER if torsion else ContactType.POINT_FRICTION
        Wb = primitive_wrenches_batch(
            positions, normals, mu=0.5, edges=8, torsion=torsion, center=center
        )
        one = []
        for b in range(12):
            grasp = [
                GraspContact(p, n, type=kind, mu=0.5, torsion=torsion)
                for p, n in zip(positions[b], normals[b])
            ]
            W, _ = primitive_wrenches(grasp, edges=8, center=center)
            np.testing.assert_allclose(Wb[b], W, atol=1e-14)
            one.append(epsilon_l1(W))
        batch = grasp_epsilon_batch(
            positions, normals, mu=0.5, edges=8, torsion=torsion, center=center
        )
        np.testing.assert_allclose(batch, epsilon_l1_batch(Wb), rtol=1e-9, atol=0)
        np.testing.assert_allclose(batch, one, rtol=1e-9, atol=0)
        assert 0 < np.count_nonzero(batch) or k == 2


def test_out_of_closure_is_zero_as_the_lp_says() -> None:
    rng = np.random.default_rng(7)
    out = 0
    for _ in range(30):
        k = int(rng.integers(2, 5))
        W, _ = primitive_wrenches(random_grasp(rng, k, mu=0.3), edges=6)
        lp = closure_lp(W)
        value = epsilon_l1_fast(W)
        assert value >= 0
        assert (value > 0) == lp.closure
        if not lp.closure:
            out += 1
            assert np.all(W @ lp.certificate >= -1e-9)
    assert out >= 5


@pytest.mark.parametrize("native", [True, False])
def test_invariances_and_degenerate_inputs(native: bool) -> None:
    """Also the qhull path alone (native=False; the compiled kernel answers most of these)."""
    rng = np.random.default_rng(2)
    W, _ = primitive_wrenches(random_grasp(rng, 4, mu=0.8), edges=8)
    e = epsilon_l1_fast(W, native=native)
    assert e > 0
    shuffled = W[rng.permutation(len(W))]
    assert epsilon_l1_fast(shuffled, native=native) == pytest.approx(e, rel=1e-12)
    assert epsilon_l1_fast(np.vstack([W, W, W[:5]]), native=native) == pytest.approx(e, rel=1e-12)
    for s in (1e-6, 1e6):
        assert epsilon_l1_fast(s * W, native=native) == pytest.approx(s * e, rel=1e-12)
    # Coplanar wrenches (rank 5 in 6-D): no hull, not in closure.
    flat = W.copy()
    flat[:, 5] = 0.0
    assert epsilon_l1_fast(flat, native=native) == 0.0
    assert epsilon_l1_fast(np.zeros((10, 6)), native=native) == 0.0
    assert epsilon_l1_fast(W[:6], native=native) == 0.0  # fewer than d + 1 points
    bad = W.copy()
    bad[3, 2] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        epsilon_l1_fast(bad)
    with pytest.raises(InvalidInputError, match=r"grasps \[1\]"):
        epsilon_l1_batch(np.stack([W, bad]))
    with pytest.raises(InvalidInputError, match=r"\(K, d\)"):
        epsilon_l1_fast(W[:, :1])
    with pytest.raises(InvalidInputError, match=r"\(B, K, d\)"):
        epsilon_l1_batch(W)
    with pytest.raises(InvalidInputError, match="normals must not be zero"):
        primitive_wrenches_batch(np.zeros((1, 2, 3)), np.zeros((1, 2, 3)))


def test_a_wrong_unmerged_hull_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A Q0 hull whose nearest facet is moved inwards fails the certificate: the merged hull
    gives the answer; a hull with a missing neighbour is refused too."""
    rng = np.random.default_rng(4)
    W, _ = primitive_wrenches(random_grasp(rng, 4, mu=0.8), edges=8)
    expected = enumerated_epsilon(W) if len(W) <= 12 else textbook_epsilon(W)
    real = eps_module.ConvexHull
    monkeypatch.setattr(eps_module, "GENERATION_MIN_WRENCHES", 10**9)  # the full-hull path

    class Corrupted:
        def __init__(self, points: np.ndarray, qhull_options: str | None = None) -> None:
            hull = real(points, qhull_options=qhull_options)
            self.equations = hull.equations.copy()
            self.neighbors = hull.neighbors.copy()
            if qhull_options == "Q0":
                self.equations[np.argmax(self.equations[:, -1]), -1] += 0.05

    monkeypatch.setattr(eps_module, "ConvexHull", Corrupted)
    assert epsilon_l1_fast(W, native=False) == pytest.approx(expected, rel=1e-9)

    class Open(Corrupted):
        def __init__(self, points: np.ndarray, qhull_options: str | None = None) -> None:
            super().__init__(points, None)
            if qhull_options == "Q0":
                self.equations[np.argmax(self.equations[:, -1]), -1] -= 0.05
                self.neighbors[0, 0] = -1

    monkeypatch.setattr(eps_module, "ConvexHull", Open)
    assert epsilon_l1_fast(W, native=False) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize(
    ("mu", "torsion", "edges"), [(0.5, 0.005, 8), (1.0, 0.02, 3), (0.3, 0.001, 5)]
)
def test_two_soft_fingers_closed_form_equals_the_hull(
    mu: float, torsion: float, edges: int
) -> None:
    """Parallel-jaw grasps (two soft fingers) are scored by enumerating their facets in
    closed form: same values as the hull of their wrenches, and (3 edges) as the facet
    enumeration without qhull."""
    rng = np.random.default_rng(int(edges))
    positions = 0.04 * rng.standard_normal((60, 2, 3))
    positions[:, 1] = -positions[:, 0] + 0.004 * rng.standard_normal((60, 3))
    normals = -positions + 0.015 * rng.standard_normal((60, 2, 3))
    center = np.array([0.002, 0.0, -0.001])
    kw = {"mu": mu, "edges": edges, "torsion": torsion, "center": center}
    fast = grasp_epsilon_batch(positions, normals, native=False, **kw)  # type: ignore[arg-type]
    W = primitive_wrenches_batch(positions, normals, **kw)  # type: ignore[arg-type]
    hull = epsilon_l1_batch(W, native=False)
    assert 10 <= np.count_nonzero(hull) <= 55  # both in and out of closure
    np.testing.assert_array_equal(fast > 0, hull > 0)
    np.testing.assert_allclose(fast, hull, rtol=1e-9, atol=0)
    if edges == 3:
        for b in range(0, 60, 6):
            assert fast[b] == pytest.approx(enumerated_epsilon(W[b]), rel=1e-9, abs=1e-14)


@pytest.mark.parametrize(("mu", "edges"), [(0.6, 8), (1.0, 4), (0.4, 5)])
def test_three_point_contacts_closed_form_equals_the_hull(mu: float, edges: int) -> None:
    """Three point contacts are scored by enumerating their facets in closed form: same
    values as the hull of their wrenches, and (4 edges) as facet enumeration without qhull;
    a symmetric grasp whose enumeration is degenerate falls back to the hull."""
    rng = np.random.default_rng(edges)
    normals = rng.standard_normal((80, 3, 3))
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    positions = -0.05 * normals + 0.01 * rng.standard_normal((80, 3, 3))
    # Three fingers at 120 deg on a disk: every contact in one plane.
    angles = 2 * np.pi * np.arange(3) / 3
    ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(3)])
    positions[0], normals[0] = 0.04 * ring, -ring
    # Two fingers on one spot: [L_1 L_2 L_3] has rank < 6, the hull decides (0: flat).
    positions[1, 1], normals[1, 1] = positions[1, 0], normals[1, 0]
    fast = grasp_epsilon_batch(positions, normals, mu=mu, edges=edges, native=False)
    n, r, rho, *_ = eps_module._contact_inputs(positions, normals, mu, edges, 0.0, None, None)
    W = primitive_wrenches_batch(positions, normals, mu=mu, edges=edges)
    closed = eps_module._three_point_contacts(W[:2], n[:2], r[:2], rho[:2], mu, edges)
    assert np.isnan(closed[1]) and np.isfinite(closed[0]) and fast[1] == 0.0
    hull = epsilon_l1_batch(W, native=False)
    assert 10 <= np.count_nonzero(hull) <= 75
    np.testing.assert_array_equal(fast > 0, hull > 0)
    np.testing.assert_allclose(fast, hull, rtol=1e-9, atol=0)
    if edges == 4:
        for b in range(0, 80, 8):
            assert fast[b] == pytest.approx(enumerated_epsilon(W[b]), rel=1e-9, abs=1e-14)


def _generated_grasps(k: int, n: int, seed: int, **kw: object) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [primitive_wrenches(random_grasp(rng, k, **kw), edges=8)[0] for _ in range(n)]


@pytest.mark.parametrize("k", [3, 4, 5])
def test_column_generation_matches_the_textbook_definition(k: int) -> None:
    """The subset hull grown by support points (``_epsilon_generated``) against one QP per
    facet of qhull's merged hull of all wrenches, and the closure LP, on random grasps; the
    generated path is the one that answered (not its full-hull fallback)."""
    used = 0
    for W in _generated_grasps(k, 6, seed=10 + k, mu=0.7):
        scale = np.abs(W).max()
        e = epsilon_l1_fast(W, native=False)
        assert e == pytest.approx(textbook_epsilon(W), rel=1e-9, abs=1e-12 * scale)
        assert (e > 0) == closure_lp(W).closure
        if not eps_module._separated(W / scale):
            used += eps_module._epsilon_generated(W / scale) is not None
    assert used >= 3


@pytest.mark.parametrize("k", [6, 8])
def test_column_generation_many_contacts_against_the_merged_hull(k: int) -> None:
    """6 and 8 contacts (48, 64 wrenches): qhull's merged hull of all wrenches (its least
    facet offset) is the reference; the generated subset stays well below all wrenches."""
    for W in _generated_grasps(k, 3, seed=20 + k, mu=0.5):
        scale = np.abs(W).max()
        offsets = -ConvexHull(W).equations[:, -1]
        expected = max(0.0, float(offsets.min()))
        expected = expected if expected > 1e-9 * scale else 0.0
        assert epsilon_l1_fast(W, native=False) == pytest.approx(
            expected, rel=1e-9, abs=1e-12 * scale
        )


@pytest.mark.parametrize("native", [True, False])
def test_column_generation_degenerate_grasps(native: bool) -> None:
    """Frictionless contacts (each cone's 8 edges coincide), coplanar contacts, and the
    origin on the boundary (two opposed frictionless pairs): values of the enumeration and
    the textbook definition; the generated path never answers wrongly, whatever it does."""
    rng = np.random.default_rng(7)
    # frictionless, 9 contacts: 72 wrenches, 9 distinct (enumerated: 84 planes)
    W, _ = primitive_wrenches(random_grasp(rng, 9, mu=0.0), edges=8)
    distinct = np.unique(W.round(15), axis=0)
    assert len(distinct) == 9
    expected = enumerated_epsilon(distinct)
    assert epsilon_l1_fast(W, native=native) == pytest.approx(expected, abs=1e-12)
    # coplanar contacts (all in z = 0, normals in the plane)
    contacts = [
        contact([0.05 * np.cos(t), 0.05 * np.sin(t), 0.0], [-np.cos(t), -np.sin(t), 0.0], mu=0.6)
        for t in 2 * np.pi * np.arange(5) / 5
    ]
    W, _ = primitive_wrenches(contacts, edges=8)
    expected = textbook_epsilon(W)
    assert epsilon_l1_fast(W, native=native) == pytest.approx(expected, rel=1e-9, abs=1e-12)
    # origin on the boundary: frictionless opposed fingers, repeated to 24 wrenches
    pair = [contact([0, 0, 0.05], [0, 0, -1], mu=0.0), contact([0, 0, -0.05], [0, 0, 1], mu=0.0)]
    W, _ = primitive_wrenches(pair * 3, edges=4)
    assert len(W) >= eps_module.GENERATION_MIN_WRENCHES
    assert epsilon_l1_fast(W, native=native) == 0.0


def test_a_wrong_subset_hull_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """An incremental hull whose nearest facet is moved inwards fails the certificate (the
    full hull answers); one whose planes are right but which stops at the first step would
    be wrong, so the support test must be what stops it."""
    W = next(w for w in _generated_grasps(5, 10, seed=31, mu=0.7) if closure_lp(w).closure)
    W = W / np.abs(W).max()
    expected = textbook_epsilon(W)
    assert expected > 0
    real = eps_module.ConvexHull

    class Corrupted:
        def __init__(self, points: np.ndarray, **kw: object) -> None:
            self._hull = real(points, **kw)  # type: ignore[arg-type]

        def __getattr__(self, name: str) -> object:
            return getattr(self._hull, name)

        @property
        def equations(self) -> np.ndarray:
            E = self._hull.equations.copy()
            E[np.argmax(E[:, -1]), -1] += 0.05
            return E

    monkeypatch.setattr(eps_module, "ConvexHull", Corrupted)
    assert eps_module._epsilon_generated(W) is None
    monkeypatch.setattr(eps_module, "ConvexHull", real)
    assert eps_module._epsilon_generated(W) == pytest.approx(expected, rel=1e-9)
