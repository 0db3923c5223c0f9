"""Grasp analysis and synthesis.

* ``epsilon``: the Ferrari-Canny epsilon (L1) of random 3- and 5-contact grasps with 8-edge
  friction cones, per grasp: taskspace (``epsilon_l1``: the compiled kernel, column
  generation on its own simplicial hull, when built), the previous paths (the same column
  generation on qhull's incremental hull, ``native=False``; one certified unmerged hull of all
  wrenches; qhull's merged hull, "Qx", the scipy default) alternated with it round by round on
  the same grasps, and the textbook reference
  written for this suite (one QP per hull facet, as Dex-Net computes it) in the same run;
  the values are checked against each other.
* ``epsilon batch``: ``grasp_epsilon_batch`` (vectorized primitive wrenches, all grasps in
  one call of the compiled kernel) against its NumPy path (``native=False``: three contacts,
  facets in closed form, all grasps at once; five, column generation on qhull per grasp) and
  ``epsilon_l1_batch(native=False)`` of the wrenches (one qhull ``epsilon_l1`` per grasp),
  alternated: grasps per second, all grasps and in-closure only (values checked equal).
* ``epsilon L-infinity``: the compiled kernel (support points of the Minkowski sum) against
  the hull of the sum (``native=False``) on 3 contacts with 4-edge cones, alternated; 5
  contacts with 8-edge cones by the kernel alone (the sum's hull is too large).
* ``closure``: the LP closure test per grasp.
* ``synthesis``: antipodal candidates sampled and scored per second on a box and a cylinder;
  scoring alone (two soft fingers: facets in closed form, all candidates at once) against the
  previous one-grasp-at-a-time loop (merged hull) on the same candidates, both with torques
  about the mesh's center of mass (``mesh.centroid``, the library's reference).

The machine is shared: each timed comparison alternates the methods over rounds and reports
the minimum and the median of the round means beside the per-call distribution.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

import taskspace.grasping.epsilon as eps_module
from benchmarks.common import Row, Timing
from benchmarks.ferrari_canny_reference import epsilon_reference
from taskspace.grasping import (
    AntipodalOptions,
    ContactType,
    GraspContact,
    box_mesh,
    closure_lp,
    cylinder_mesh,
    epsilon_l1,
    epsilon_l1_batch,
    epsilon_l1_fast,
    epsilon_linf,
    grasp_epsilon_batch,
    primitive_wrenches,
    primitive_wrenches_batch,
    sample_antipodal_grasps,
)
from taskspace.grasping.quality import _margin, wrench_space_l1

SUITE = "grasping"


def _contacts(k: int, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` grasps of ``k`` contacts on a 5 cm sphere, inward normals (the scene)."""
    normals = rng.standard_normal((n, k, 3))
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    return -0.05 * normals, normals


def _grasps(k: int, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    positions, normals = _contacts(k, n, rng)
    out = []
    for p, m in zip(positions, normals):
        W, _ = primitive_wrenches([GraspContact(a, b, mu=0.6) for a, b in zip(p, m)], edges=8)
        out.append(W)
    return out


def _epsilon_merged(W: np.ndarray) -> float:
    """The previous epsilon_l1: qhull's merged hull (scipy default options), facet offsets."""
    return _margin(wrench_space_l1(W))


def _epsilon_qhull_generated(W: np.ndarray) -> float:
    """The previous epsilon_l1: column generation on qhull's incremental hull (no kernel)."""
    return epsilon_l1_fast(W, native=False)


def _epsilon_full_hull(W: np.ndarray) -> float:
    """The previous epsilon_l1: one certified unmerged hull (Q0) of all wrenches."""
    scale = float(np.abs(W).max())
    Wn = W / scale
    return 0.0 if eps_module._separated(Wn) else eps_module._epsilon_full(Wn) * scale


def _per_call(fn: Callable[[Any], Any], items: list[Any]) -> tuple[list[float], list[Any]]:
    times, values = [], []
    for x in items:
        t0 = time.perf_counter()
        values.append(fn(x))
        times.append(time.perf_counter() - t0)
    return times, values


def _alternate(
    fns: list[Callable[[Any], Any]], items: list[Any], rounds: int
) -> tuple[list[list[float]], list[list[float]], list[list[Any]]]:
    """Per-call times of each function over ``rounds`` alternating passes, round means."""
    samples: list[list[float]] = [[] for _ in fns]
    means: list[list[float]] = [[] for _ in fns]
    values: list[list[Any]] = [[] for _ in fns]
    for r in range(rounds):
        order = range(len(fns)) if r % 2 == 0 else reversed(range(len(fns)))
        for i in order:
            t, v = _per_call(fns[i], items)
            samples[i] += t
            means[i].append(float(np.mean(t)))
            values[i] = v
    return samples, means, values


def _round_stats(means: list[float]) -> dict[str, float]:
    return {
        "round_mean_min_us": 1e6 * min(means),
        "round_mean_median_us": 1e6 * float(np.median(means)),
        "rounds": len(means),
    }


def _epsilon_rows(quick: bool, rng: np.random.Generator) -> list[Row]:
    rows: list[Row] = []
    n = 30 if quick else 200
    rounds = 3 if quick else 5
    for k in (3, 5):
        grasps = _grasps(k, n, rng)
        times, means, values = _alternate(
            [epsilon_l1, _epsilon_qhull_generated, _epsilon_full_hull, _epsilon_merged],
            grasps,
            rounds,
        )
        (t_new, t_gen, t_full, t_old), (m_new, m_gen, m_full, m_old) = times, means
        v_new, v_gen, v_full, v_old = values
        ref_items = grasps[: max(5, n // 10)]  # the reference is slow
        t_ref, v_ref = _per_call(epsilon_reference, ref_items)
        scale = max(1e-300, max(v_ref))
        err_ref = max(abs(a - b) / max(b, 1e-12 * scale) for a, b in zip(v_new, v_ref))
        err_old = max(abs(a - b) / max(b, 1e-12) for a, b in zip(v_new, v_old))
        err_full = max(abs(a - b) / max(b, 1e-12) for a, b in zip(v_new, v_full))
        err_gen = max(abs(a - b) / max(b, 1e-12) for a, b in zip(v_new, v_gen))
        scene = f"epsilon L1, {k} contacts, 8-edge cones"
        closed = float(np.mean([v > 0 for v in v_new]))
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace",
                Timing.from_samples(t_new),
                {
                    "grasps_per_s": 1 / np.median(t_new),
                    "in_closure": closed,
                    "max_rel_diff_to_reference": err_ref,
                    "max_rel_diff_to_merged_hull": err_old,
                    "max_rel_diff_to_full_hull": err_full,
                    "max_rel_diff_to_qhull_generation": err_gen,
                    **_round_stats(m_new),
                },
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace before: column generation on qhull (native=False)",
                Timing.from_samples(t_gen),
                _round_stats(m_gen),
                ratio_to="taskspace",
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace before: one certified hull of all wrenches (Q0)",
                Timing.from_samples(t_full),
                _round_stats(m_full),
                ratio_to="taskspace",
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace before: merged qhull (Qx)",
                Timing.from_samples(t_old),
                _round_stats(m_old),
                ratio_to="taskspace",
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                "reference: one QP per facet",
                Timing.from_samples(t_ref),
                {"grasps": len(ref_items)},
                ratio_to="taskspace",
            )
        )
        t_lp, _ = _per_call(closure_lp, grasps)
        rows.append(Row(SUITE, f"closure LP, {k} contacts", "taskspace", Timing.from_samples(t_lp)))
    return rows


def _batch_rows(quick: bool, rng: np.random.Generator) -> list[Row]:
    rows: list[Row] = []
    n = 200 if quick else 2000
    rounds = 3 if quick else 5
    for k in (3, 5):
        positions, normals = _contacts(k, n, rng)
        inside = grasp_epsilon_batch(positions, normals, mu=0.6, edges=8) > 0

        def batch(sel: Any, p: np.ndarray = positions, m: np.ndarray = normals) -> np.ndarray:
            return grasp_epsilon_batch(p[sel], m[sel], mu=0.6, edges=8)

        def numpy(sel: Any, p: np.ndarray = positions, m: np.ndarray = normals) -> np.ndarray:
            return grasp_epsilon_batch(p[sel], m[sel], mu=0.6, edges=8, native=False)

        def hulls(sel: Any, p: np.ndarray = positions, m: np.ndarray = normals) -> np.ndarray:
            W = primitive_wrenches_batch(p[sel], m[sel], mu=0.6, edges=8)
            return epsilon_l1_batch(W, native=False)

        everything = slice(None)
        (t_b, t_n, t_h), _, (v_b, v_n, v_h) = _alternate(
            [batch, numpy, hulls], [everything, inside], rounds
        )
        for v in (v_n, v_h):
            np.testing.assert_allclose(v_b[0], v[0], rtol=1e-9, atol=0)
            np.testing.assert_allclose(v_b[1], v[1], rtol=1e-9, atol=0)
        closed = max(1, int(inside.sum()))
        scene = f"epsilon L1 batch, {k} contacts, 8-edge cones"
        for method, t, ratio_to in (
            ("taskspace", t_b, None),
            ("taskspace before: grasp_epsilon_batch(native=False)", t_n, "taskspace"),
            ("taskspace: epsilon_l1_batch(native=False) (one qhull per grasp)", t_h, "taskspace"),
        ):
            every, only = np.array(t[0::2]) / n, np.array(t[1::2]) / closed
            rows.append(
                Row(
                    SUITE,
                    scene,
                    method,
                    Timing.from_samples(every),
                    {
                        "batch": n,
                        "grasps_per_s": 1 / every.min(),
                        "grasps_per_s_median": 1 / float(np.median(every)),
                        "in_closure": float(inside.mean()),
                        "in_closure_only_grasps_per_s": 1 / only.min(),
                        "in_closure_only_grasps_per_s_median": 1 / float(np.median(only)),
                        "rounds": rounds,
                    },
                    ratio_to=ratio_to,
                )
            )
    return rows


def _score_one_by_one(cands: Any, center: np.ndarray) -> np.ndarray:
    """The previous scoring loop of sample_antipodal_grasps (one grasp at a time, merged)."""
    o = cands.options
    out = np.empty(len(cands))
    for i in range(len(cands)):
        contacts = [
            GraspContact(p, m, type=ContactType.SOFT_FINGER, mu=o.mu, torsion=o.torsion)
            for p, m in ((cands.p1[i], cands.n1[i]), (cands.p2[i], cands.n2[i]))
        ]
        W, _ = primitive_wrenches(contacts, edges=o.edges, center=center)
        out[i] = _epsilon_merged(W)
    return out


def _synthesis_rows(quick: bool, rng: np.random.Generator) -> list[Row]:
    rows: list[Row] = []
    rounds = 3
    for name, mesh in (
        ("box 5x6x12 cm", box_mesh([0.05, 0.06, 0.12])),
        ("cylinder r3 h12 cm", cylinder_mesh(0.03, 0.12)),
    ):
        samples = 300 if quick else 2000
        totals = []
        for _ in range(rounds):
            t0 = time.perf_counter()
            cands = sample_antipodal_grasps(mesh, rng, AntipodalOptions(samples=samples))
            totals.append((time.perf_counter() - t0) / max(1, len(cands)))
        center = mesh.centroid  # the library's reference (sample_antipodal_grasps scores about it)

        def batch(c: Any, m: np.ndarray = center) -> np.ndarray:
            o = c.options
            return grasp_epsilon_batch(
                np.stack([c.p1, c.p2], axis=1),
                np.stack([c.n1, c.n2], axis=1),
                mu=o.mu,
                edges=o.edges,
                torsion=o.torsion,
                center=m,
            )

        def loop(c: Any, m: np.ndarray = center) -> np.ndarray:
            return _score_one_by_one(c, m)

        (t_b, t_l), (m_b, m_l), (v_b, v_l) = _alternate([batch, loop], [cands], rounds)
        per = max(1, len(cands))
        np.testing.assert_allclose(v_b[0], v_l[0], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(v_b[0], cands.epsilon, rtol=0, atol=0)
        rows.append(
            Row(
                SUITE,
                f"antipodal synthesis, {name}",
                "taskspace",
                Timing.from_samples(totals),
                {
                    "samples": samples,
                    "candidates": len(cands),
                    "candidates_scored_per_s": 1 / min(totals),
                    "candidates_scored_per_s_median": 1 / float(np.median(totals)),
                },
            )
        )
        scene = f"antipodal scoring only, {name}"
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace",
                Timing.from_samples(np.array(t_b) / per),
                {"candidates_per_s": per / min(t_b), **_round_stats(np.array(m_b) / per)},
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace before: one by one, merged qhull",
                Timing.from_samples(np.array(t_l) / per),
                {"candidates_per_s": per / min(t_l), **_round_stats(np.array(m_l) / per)},
                ratio_to="taskspace",
            )
        )
    return rows


def _linf_rows(quick: bool, rng: np.random.Generator) -> list[Row]:
    """L-infinity epsilon per grasp: the compiled kernel (support of the Minkowski sum)
    alternated with the hull of the sum (native=False) on 3 contacts with 4-edge cones; 5
    contacts with 8-edge cones only by the kernel (the sum's hull is refused: too large)."""
    rows: list[Row] = []
    positions, normals = _contacts(3, 4 if quick else 8, rng)
    grasps = [
        primitive_wrenches([GraspContact(a, b, mu=0.6) for a, b in zip(p, m)], edges=4)
        for p, m in zip(positions, normals)
    ]

    def native(g: Any) -> float:
        return epsilon_linf(*g)

    def hull(g: Any) -> float:
        return epsilon_linf(*g, native=False)

    (t_n, t_h), (m_n, m_h), (v_n, v_h) = _alternate([native, hull], grasps, 2)
    np.testing.assert_allclose(v_n, v_h, rtol=1e-9, atol=1e-15)
    scene = "epsilon L-infinity, 3 contacts, 4-edge cones"
    rows.append(
        Row(
            SUITE,
            scene,
            "taskspace",
            Timing.from_samples(t_n),
            {"in_closure": float(np.mean([v > 0 for v in v_n])), **_round_stats(m_n)},
        )
    )
    rows.append(
        Row(
            SUITE,
            scene,
            "taskspace before: hull of the Minkowski sum (native=False)",
            Timing.from_samples(t_h),
            _round_stats(m_h),
            ratio_to="taskspace",
        )
    )
    positions, normals = _contacts(5, 30 if quick else 200, rng)
    grasps = [
        primitive_wrenches([GraspContact(a, b, mu=0.6) for a, b in zip(p, m)], edges=8)
        for p, m in zip(positions, normals)
    ]
    t, v = _per_call(native, grasps)
    rows.append(
        Row(
            SUITE,
            "epsilon L-infinity, 5 contacts, 8-edge cones",
            "taskspace",
            Timing.from_samples(t),
            {"grasps_per_s": 1 / np.median(t), "in_closure": float(np.mean([x > 0 for x in v]))},
        )
    )
    return rows


def run(quick: bool) -> list[Row]:
    rng = np.random.default_rng(0)
    return (
        _epsilon_rows(quick, rng)
        + _batch_rows(quick, rng)
        + _linf_rows(quick, rng)
        + _synthesis_rows(quick, rng)
    )
