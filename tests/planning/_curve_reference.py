"""Independent references for Dubins / Reeds-Shepp tests.

* the 48 Reeds-Shepp words, generated from the 9 groups of the paper's table by the
  time-flip and reflection symmetries;
* a brute-force numeric solver: for every word, multi-start bounded least squares on the
  3 free segment lengths (complex-number arc composition), keeping exact roots;
* a numerical integration of the car ODE of slide 3:47 with scipy's DOP853.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

HP = np.pi / 2

# Each segment: (letter, sign, kind) with kind "a", "b", "c" (free parameters), "h" (pi/2).
RS_GROUPS = {
    "C|C|C": [("L", 1, "a"), ("R", -1, "b"), ("L", 1, "c")],
    "CC|C": [("L", 1, "a"), ("R", 1, "b"), ("L", -1, "c")],
    "C|CC": [("L", 1, "a"), ("R", -1, "b"), ("L", -1, "c")],
    "CSC1": [("L", 1, "a"), ("S", 1, "b"), ("L", 1, "c")],
    "CSC2": [("L", 1, "a"), ("S", 1, "b"), ("R", 1, "c")],
    "CCu|CuC": [("L", 1, "a"), ("R", 1, "b"), ("L", -1, "b"), ("R", -1, "c")],
    "C|CuCu|C": [("L", 1, "a"), ("R", -1, "b"), ("L", -1, "b"), ("R", 1, "c")],
    "C|C2SC1": [("L", 1, "a"), ("R", -1, "h"), ("S", -1, "b"), ("L", -1, "c")],
    "C|C2SC2": [("L", 1, "a"), ("R", -1, "h"), ("S", -1, "b"), ("R", -1, "c")],
    "CSC2|C1": [("L", 1, "a"), ("S", 1, "b"), ("R", 1, "h"), ("L", -1, "c")],
    "CSC2|C2": [("R", 1, "a"), ("S", 1, "b"), ("R", 1, "h"), ("L", -1, "c")],
    "C|C2SC2|C": [("L", 1, "a"), ("R", -1, "h"), ("S", -1, "b"), ("L", -1, "h"), ("R", 1, "c")],
}


def rs_words() -> list[list[tuple[str, int, str]]]:
    words = {}
    swap = {"L": "R", "R": "L", "S": "S"}
    for base in RS_GROUPS.values():
        for flip, refl in itertools.product((1, -1), (False, True)):
            w = [(swap[c] if refl else c, s * flip, k) for c, s, k in base]
            words["".join(f"{c}{'+' if s > 0 else '-'}" for c, s, _ in w)] = w
    return list(words.values())


def dubins_words() -> list[list[tuple[str, int, str]]]:
    return [
        [(c, 1, k) for c, k in zip(w, "abc")] for w in ("LSL", "RSR", "LSR", "RSL", "RLR", "LRL")
    ]


def endpoint(word, params, radius: float) -> np.ndarray:
    """End pose by composing exact arcs with complex numbers (start at the origin)."""
    z = 0j
    th = 0.0
    for c, s, k in word:
        ell = HP * radius if k == "h" else params["abc".index(k)]
        ell *= s
        if c == "S":
            z += ell * np.exp(1j * th)
        else:
            kap = (1.0 if c == "L" else -1.0) / radius
            z += np.exp(1j * th) * (np.exp(1j * kap * ell) - 1.0) / (1j * kap)
            th += kap * ell
    return np.array([z.real, z.imag, th])


def brute_force_length(word, goal_local, radius, n_grid=3) -> float:
    """Shortest exact solution of one word, by multi-start root finding (inf if none).

    Arc parameters are reduced modulo a full turn (which leaves the end pose unchanged);
    a root is kept only if every straight-segment parameter is non-negative.
    """
    kinds = sorted({k for _, _, k in word if k != "h"})
    straight = {k for c, _, k in word if c == "S"}
    d = float(np.hypot(goal_local[0], goal_local[1]))
    hi = {k: (d + 4 * radius if k in straight else 2 * np.pi * radius) for k in kinds}
    goal = np.asarray(goal_local, dtype=float)

    def res(z):
        p = np.zeros(3)
        for k, val in zip(kinds, z):
            p["abc".index(k)] = val
        e = endpoint(word, p, radius)
        out = e - goal
        out[2] = (out[2] + np.pi) % (2 * np.pi) - np.pi
        return out

    best = np.inf
    grid = [(i + 0.5) / n_grid for i in range(n_grid)]
    for frac in itertools.product(grid, repeat=len(kinds)):
        z0 = np.array([f * hi[k] for k, f in zip(kinds, frac)])
        sol = root(res, z0, method="hybr", options={"xtol": 1e-14})
        z = sol.x.copy()
        for i, k in enumerate(kinds):
            if k not in straight:
                z[i] = np.mod(z[i], 2 * np.pi * radius)
                if z[i] > 2 * np.pi * radius - 1e-9:
                    z[i] = 0.0
        if any(z[i] < -1e-9 for i, k in enumerate(kinds) if k in straight):
            continue
        if np.max(np.abs(res(z))) < 1e-9:
            val = dict(zip(kinds, z))
            total = sum(HP * radius if k == "h" else abs(val[k]) for _, _, k in word)
            best = min(best, total)
    return best


def integrate_car(start, controls, wheelbase: float) -> np.ndarray:
    """Integrate xdot = v cos th, ydot = v sin th, thdot = v tan(phi) / L segment by segment."""
    q = np.asarray(start, dtype=float)
    for v, phi, dur in controls:
        if dur <= 0:
            continue

        def f(_t, s, v=v, phi=phi):
            return [v * np.cos(s[2]), v * np.sin(s[2]), v * np.tan(phi) / wheelbase]

        sol = solve_ivp(f, (0.0, dur), q, method="DOP853", rtol=1e-13, atol=1e-13)
        q = sol.y[:, -1]
    return q
