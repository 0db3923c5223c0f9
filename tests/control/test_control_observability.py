from __future__ import annotations

import control as ct
import numpy as np
import pytest

from taskspace.control import (
    controllability,
    is_observable,
    kalman_decomposition,
    observability,
    observability_matrix,
)
from taskspace.control._linear import safe_norm
from taskspace.errors import UnknownNameError


@pytest.mark.parametrize("seed", range(4))
def test_observability_matrix_matches_python_control(seed: int) -> None:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(5, 5))
    C = rng.normal(size=(2, 5))
    assert np.allclose(observability_matrix(A, C), ct.obsv(A, C))
    assert is_observable(A, C)


def test_unobservable_modes_and_detectability() -> None:
    A = np.diag([-1.0, 2.0, -3.0])
    C = np.array([[0.0, 1.0, 0.0]])
    rep = observability(A, C)
    assert rep.rank == np.linalg.matrix_rank(ct.obsv(A, C)) == 1
    assert not rep.observable
    assert np.allclose(np.sort(rep.unobservable_modes.real), [-3.0, -1.0])
    assert rep.detectable()
    rep2 = observability(A, [[1.0, 0.0, 0.0]])
    assert not rep2.detectable()  # the unstable mode 2 is unobservable


def _transfer(A, B, C, s):  # type: ignore[no-untyped-def]
    return C @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B)


def _hidden_system(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """A system with known parts (1 or 2 states each) hidden by a random basis, and the parts'
    sizes (co, cu, uo, uu)."""
    rng = np.random.default_rng(100 + seed)
    # Build a system with known parts (1 or 2 states each) and hide it by a random basis.
    sizes = [2, 1, 1, 2] if seed % 2 else [1, 2, 2, 1]
    n = sum(sizes)
    s = np.cumsum([0, *sizes])
    co, cu, uo, uu = (slice(s[i], s[i + 1]) for i in range(4))
    Az = np.zeros((n, n))
    for blk_r, blk_c in [
        (co, co),
        (co, uo),
        (cu, co),
        (cu, cu),
        (cu, uo),
        (cu, uu),
        (uo, uo),
        (uu, uo),
        (uu, uu),
    ]:
        Az[blk_r, blk_c] = rng.normal(size=(blk_r.stop - blk_r.start, blk_c.stop - blk_c.start))
    Bz = np.zeros((n, 2))
    Bz[co] = rng.normal(size=(sizes[0], 2))
    Bz[cu] = rng.normal(size=(sizes[1], 2))
    Cz = np.zeros((2, n))
    Cz[:, co] = rng.normal(size=(2, sizes[0]))
    Cz[:, uo] = rng.normal(size=(2, sizes[2]))
    T = rng.normal(size=(n, n))
    A = T @ Az @ np.linalg.inv(T)
    B = T @ Bz
    C = Cz @ np.linalg.inv(T)
    return A, B, C, sizes


@pytest.mark.parametrize("seed", range(4))
def test_kalman_decomposition_structure(seed: int) -> None:
    A, B, C, sizes = _hidden_system(seed)
    dec = kalman_decomposition(A, B, C)
    assert dec.sizes == tuple(sizes)
    # Ranks against python-control's controllability / observability matrices.
    n_c = np.linalg.matrix_rank(ct.ctrb(A, B), tol=1e-8)
    n_o = np.linalg.matrix_rank(ct.obsv(A, C), tol=1e-8)
    assert n_c == sizes[0] + sizes[1]
    assert n_o == sizes[0] + sizes[2]
    a, b, c = dec.A, dec.B, dec.C
    p = {k: dec.part(k) for k in ("co", "cu", "uo", "uu")}
    tol = 1e-8 * max(1.0, np.abs(a).max())
    for r, col in [
        ("co", "cu"),
        ("co", "uu"),
        ("uo", "co"),
        ("uo", "cu"),
        ("uo", "uu"),
        ("uu", "co"),
        ("uu", "cu"),
    ]:
        assert np.abs(a[p[r], p[col]]).max(initial=0.0) < tol, (r, col)
    assert np.abs(b[p["uo"]]).max(initial=0.0) < 1e-8
    assert np.abs(b[p["uu"]]).max(initial=0.0) < 1e-8
    assert np.abs(c[:, p["cu"]]).max(initial=0.0) < 1e-8
    assert np.abs(c[:, p["uu"]]).max(initial=0.0) < 1e-8
    # The minimal realization has the same transfer function as the full system.
    Am, Bm, Cm = dec.minimal()
    for s_ in (0.3 + 1.0j, 2.0, -0.7 + 0.1j):
        assert np.allclose(_transfer(Am, Bm, Cm, s_), _transfer(A, B, C, s_), atol=1e-8)
    assert np.allclose(np.linalg.inv(dec.T) @ A @ dec.T, a)


@pytest.mark.parametrize("scale", [1e-12, 1e-6, 1e8, 1e50, 1e300])
@pytest.mark.parametrize("seed", range(4))
def test_kalman_decomposition_of_a_scaled_a_has_the_same_parts(seed: int, scale: float) -> None:
    # The controllable and unobservable subspaces of (s A, B, C) are those of (A, B, C) for
    # every s != 0 (the Krylov spaces of s A and A are the same): the parts' sizes are the
    # constructed ones at every scale (a common scale of the controllability matrix made B
    # vanish next to (s A)^2 B: sizes (0, 1, 1, 1) instead of (2, 0, 0, 1) from s = 1e50 on).
    A, B, C, sizes = _hidden_system(seed)
    dec = kalman_decomposition(scale * A, B, C)
    assert dec.sizes == tuple(sizes)
    p = {k: dec.part(k) for k in ("co", "cu", "uo", "uu")}
    a = dec.A / scale  # T^-1 (s A) T / s
    tol = 1e-7 * max(1.0, np.abs(a).max())
    for r, col in [("co", "cu"), ("co", "uu"), ("uo", "co"), ("uo", "cu"), ("uu", "co")]:
        assert np.abs(a[p[r], p[col]]).max(initial=0.0) < tol, (r, col)
    assert np.abs(dec.B[p["uo"]]).max(initial=0.0) < 1e-7
    assert np.abs(dec.C[:, p["cu"]]).max(initial=0.0) < 1e-7


def test_a_small_chain_keeps_its_parts_at_every_scale() -> None:
    # x1' = x2, x2' = u, x3' = -x3, y = x1: x1, x2 controllable and observable, x3 neither
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    for scale in (1e-12, 1.0, 1e50, 1e300):
        dec = kalman_decomposition(scale * A, [[0.0], [1.0], [0.0]], [[1.0, 0.0, 0.0]])
        assert dec.sizes == (2, 0, 0, 1), scale


def test_part_names() -> None:
    dec = kalman_decomposition(np.eye(2), [[1.0], [0.0]], [[1.0, 0.0]])
    with pytest.raises(UnknownNameError, match="co, cu, uo, uu"):
        dec.part("xx")


@pytest.mark.parametrize("scale", [1e-200, 1.0, 1e200])
def test_kalman_decomposition_of_a_system_in_one_part(scale: float) -> None:
    # A chain x1' = x2, x2' = x3, x3' = -x1 - 2 x2 - 3 x3: controllable from u (x3'), observable
    # from y = x1; with B or C zero every state moves to the uncontrollable or unobservable
    # parts. Fully controllable, I - R R^T is zero up to rounding: a threshold relative to
    # its largest singular value kept them all and put the 3 states in "uo" (sizes (0, 0, 3,
    # 0) at every scale before).
    A = scale * np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -2.0, -3.0]])
    B, C = np.array([[0.0], [0.0], [1.0]]), np.array([[1.0, 0.0, 0.0]])
    zb, zc = np.zeros((3, 1)), np.zeros((1, 3))
    assert kalman_decomposition(A, B, C).sizes == (3, 0, 0, 0)
    assert kalman_decomposition(A, B, zc).sizes == (0, 3, 0, 0)
    assert kalman_decomposition(A, zb, C).sizes == (0, 0, 3, 0)
    assert kalman_decomposition(A, zb, zc).sizes == (0, 0, 0, 3)


@pytest.mark.parametrize("scale", [1e-100, 1e-200, 1e-300, 1e-320])
def test_tiny_a_keeps_its_rank_and_modes(scale: float) -> None:
    # The Krylov columns of s A are s^k A^k B: for a tiny s their norms underflowed (A^2 B ~
    # 1e-200 squared to 0: the column dropped, rank 2) or A^2 B itself did (~1e-400); the test
    # now runs on 2^-e A (exact). Controllability and observability are those of A.
    A0 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -2.0, -3.0]])
    B, C = np.array([[0.0], [0.0], [1.0]]), np.array([[1.0, 0.0, 0.0]])
    ctrb = controllability(scale * A0, B)
    assert ctrb.controllable and ctrb.rank == 3
    assert ctrb.uncontrollable_modes.size == 0
    obsv = observability(scale * A0, C)
    assert obsv.rank == 3 and obsv.unobservable_modes.size == 0
    # x3 decoupled and not driven: its mode -3 s is the one uncontrollable mode
    A1, B1 = np.diag([-1.0, -2.0, -3.0]), np.array([[1.0], [1.0], [0.0]])
    part = controllability(scale * A1, B1)
    assert part.rank == 2
    np.testing.assert_allclose(part.uncontrollable_modes.real / scale, [-3.0], rtol=1e-12)


def test_safe_norm_of_tiny_entries() -> None:
    # np.linalg.norm squares the entries: (3e-200, 4e-200) had norm 0
    assert safe_norm(np.array([3e-200, 4e-200])) == pytest.approx(5e-200, rel=1e-15)
    cols = safe_norm(np.array([[3e-200, 1.0], [4e-200, 0.0]]), axis=0)
    np.testing.assert_allclose(cols, [5e-200, 1.0], rtol=1e-15)
