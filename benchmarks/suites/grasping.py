"""Grasp analysis and synthesis.

* ``epsilon``: the Ferrari-Canny epsilon (L1) of random 3- and 5-contact grasps with 8-edge
  friction cones, per grasp: taskspace (one convex hull, facet offsets) against the textbook
  reference written for this suite (one QP per hull facet, as Dex-Net computes it), same
  grasps, same values checked.
* ``closure``: the LP closure test per grasp.
* ``synthesis``: antipodal candidates sampled and scored per second on a box and a cylinder.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import Row, Timing
from benchmarks.ferrari_canny_reference import epsilon_reference
from taskspace.grasping import (
    AntipodalOptions,
    GraspContact,
    box_mesh,
    closure_lp,
    cylinder_mesh,
    epsilon_l1,
    primitive_wrenches,
    sample_antipodal_grasps,
)

SUITE = "grasping"


def _grasps(k: int, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    out = []
    while len(out) < n:
        normals = rng.standard_normal((k, 3))
        positions = -normals / np.linalg.norm(normals, axis=1, keepdims=True) * 0.05
        grasp = [GraspContact(p, m, mu=0.6) for p, m in zip(positions, normals)]
        W, _ = primitive_wrenches(grasp, edges=8)
        out.append(W)
    return out


def _per_call(fn, items) -> tuple[list[float], list[float]]:
    times, values = [], []
    for x in items:
        t0 = time.perf_counter()
        values.append(fn(x))
        times.append(time.perf_counter() - t0)
    return times, values


def run(quick: bool) -> list[Row]:
    rng = np.random.default_rng(0)
    rows: list[Row] = []
    n = 30 if quick else 200
    for k in (3, 5):
        grasps = _grasps(k, n, rng)
        t_ours, v_ours = _per_call(epsilon_l1, grasps)
        ref_items = grasps[: max(5, n // 10)]  # the reference is slow
        t_ref, v_ref = _per_call(epsilon_reference, ref_items)
        err = max(abs(a - b) for a, b in zip(v_ours, v_ref))
        scene = f"epsilon L1, {k} contacts, 8-edge cones"
        closed = float(np.mean([v > 0 for v in v_ours]))
        rows.append(
            Row(
                SUITE,
                scene,
                "taskspace",
                Timing.from_samples(t_ours),
                {
                    "grasps_per_s": 1 / np.median(t_ours),
                    "in_closure": closed,
                    "max_abs_diff_to_reference": err,
                },
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
    for name, mesh in (
        ("box 5x6x12 cm", box_mesh([0.05, 0.06, 0.12])),
        ("cylinder r3 h12 cm", cylinder_mesh(0.03, 0.12)),
    ):
        samples = 300 if quick else 2000
        t0 = time.perf_counter()
        cands = sample_antipodal_grasps(mesh, rng, AntipodalOptions(samples=samples))
        t = time.perf_counter() - t0
        rows.append(
            Row(
                SUITE,
                f"antipodal synthesis, {name}",
                "taskspace",
                Timing.from_samples([t / max(1, len(cands))]),
                {
                    "samples": samples,
                    "candidates": len(cands),
                    "candidates_scored_per_s": len(cands) / t,
                },
            )
        )
    return rows
