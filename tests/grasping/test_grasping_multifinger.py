"""Multi-finger contact sets: in force closure by an independent test, on the surface, scored."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.grasping import (
    MultiFingerOptions,
    box_mesh,
    closure_lp,
    epsilon_l1,
    primitive_wrenches,
    sample_multifinger_grasps,
)

HALF = np.array([0.03, 0.04, 0.06])


@pytest.fixture(scope="module")
def box_candidates():  # type: ignore[no-untyped-def]
    mesh = box_mesh(2 * HALF)
    options = MultiFingerOptions(fingers=3, samples=120, mu=0.6, min_spacing=0.02)
    return mesh, sample_multifinger_grasps(mesh, np.random.default_rng(3), options)


def test_every_candidate_is_in_closure_by_the_lp_and_sorted(box_candidates) -> None:  # type: ignore[no-untyped-def]
    _, cands = box_candidates
    assert 0 < len(cands) < cands.sampled  # some sets fail closure (e.g. all on one face)
    assert np.all(np.diff(cands.epsilon) <= 0)
    for i in range(len(cands)):
        W, _ = primitive_wrenches(cands.contacts(i), edges=8, center=cands.center)
        assert closure_lp(W).closure  # the LP test, independent of the hull that scored it
        # the metric does not depend on the order of the fingers
        Wr, _ = primitive_wrenches(cands.contacts(i)[::-1], edges=8, center=cands.center)
        assert epsilon_l1(Wr) == pytest.approx(cands.epsilon[i], rel=1e-9)


def test_contacts_lie_on_the_box_faces_with_inward_normals(box_candidates) -> None:  # type: ignore[no-untyped-def]
    _, cands = box_candidates
    p, n = cands.points.reshape(-1, 3), cands.normals.reshape(-1, 3)
    on_face = np.isclose(np.abs(p), HALF, atol=1e-12)
    assert np.all(on_face.sum(axis=1) >= 1)
    # the inward normal of the face a point lies on: -sign(p) along that axis
    for x, m, f in zip(p, n, on_face):
        axis = int(np.flatnonzero(f)[0])
        expect = np.zeros(3)
        expect[axis] = -np.sign(x[axis])
        assert m == pytest.approx(expect, abs=1e-12)
    gaps = np.linalg.norm(cands.points[:, :, None] - cands.points[:, None, :], axis=-1)
    assert np.all(gaps[:, [0, 0, 1], [1, 2, 2]] >= 0.02)


def test_frictionless_points_never_close_and_more_friction_scores_higher() -> None:
    mesh = box_mesh(2 * HALF)
    rng = np.random.default_rng(0)
    none = sample_multifinger_grasps(mesh, rng, MultiFingerOptions(fingers=3, mu=0.0))
    assert len(none) == 0  # 3 frictionless points cannot hold a body (6 needed)
    low = sample_multifinger_grasps(
        mesh, np.random.default_rng(1), MultiFingerOptions(fingers=4, samples=80, mu=0.3)
    )
    high = sample_multifinger_grasps(
        mesh, np.random.default_rng(1), MultiFingerOptions(fingers=4, samples=80, mu=0.9)
    )
    assert len(high) >= len(low) > 0  # same contact sets: more of them close with more friction
    assert high.epsilon[0] > low.epsilon[0]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fingers": 1}, "fingers"),
        ({"samples": 0}, "samples"),
        ({"mu": -0.1}, "mu"),
        ({"min_spacing": float("nan")}, "min_spacing"),
        ({"edges": 2}, "edges"),
    ],
)
def test_bad_options_are_refused(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        MultiFingerOptions(**kwargs)  # type: ignore[arg-type]
