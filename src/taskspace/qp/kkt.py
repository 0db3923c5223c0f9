"""KKT residuals of a QP solution: the certificate behind a ``SOLVED`` status.

For ``min 1/2 x'Hx + g'x  s.t.  A x = b,  l <= C x <= u,  lb <= x <= ub`` with multipliers
``y`` (equalities), ``z`` (inequalities) and ``z_box`` (bounds), signed as proxsuite and daqp
sign them (positive on an active upper bound, negative on an active lower bound):

* primal residual ``r_p = max(|A x - b|, [l - C x]^+, [C x - u]^+, [lb - x]^+, [x - ub]^+)``;
* dual residual ``r_d = |H x + g + A'y + C'z + z_box|`` (stationarity);
* complementarity ``r_c = max_i min(|z_i|, s_i)`` with ``s_i`` the slack of the bound ``z_i``
  pushes against (``u_i - (Cx)_i`` for ``z_i > 0``, ``(Cx)_i - l_i`` for ``z_i < 0``), box
  rows included: a multiplier on a row that is not at its bound (the min-map residual of
  nonlinear complementarity problems, which stays meaningful when degenerate active sets
  make multipliers huge);
* duality gap ``|x'Hx + g'x + b'y + u'z^+ - l'z^- + ub'z_box^+ - lb'z_box^-|``.

A solution is accepted when ``r_p <= eps_abs + eps_rel s_p``, ``r_d <= eps_abs + eps_rel s_d``
and ``r_c <= eps_abs + eps_rel max(s_p, s_d)`` with the scales ``s_p = max(|x|, |b|, |Cx|)``
and ``s_d = max(|Hx|, |g|, |A'y + C'z + z_box|)`` (the scales of proxsuite's own primal and
dual tests). Complementarity is what proxsuite's default test omits: it then stops at points
whose multipliers belong to another active set. The duality gap is reported with its scale
``max(1, |x'Hx|, |g'x|, |b'y|)``, not tested (huge multipliers of degenerate active sets
make it large at exact solutions).

Thread safety: the functions keep their state local to the call; :class:`KKTResiduals` is an
immutable value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray
from taskspace.qp.problem import QPProblem

_max = np.maximum.reduce  # twice as fast as ndarray.max on small vectors


@dataclass(frozen=True)
class KKTResiduals:
    """Residuals of the KKT conditions at a solution (see the module docstring).

    Attributes:
        primal: largest constraint violation.
        dual: largest stationarity error (and multiplier sign error).
        complementarity: largest ``min(|z_i|, slack_i)``.
        duality_gap: primal minus dual objective.
        primal_scale, dual_scale, gap_scale: magnitudes the relative tolerances multiply.
    """

    primal: float
    dual: float
    complementarity: float
    duality_gap: float
    primal_scale: float = 1.0
    dual_scale: float = 1.0
    gap_scale: float = 1.0

    def within(self, eps_abs: float, eps_rel: float) -> bool:
        """Whether every residual meets ``eps_abs + eps_rel * scale``."""
        return (
            self.primal <= eps_abs + eps_rel * self.primal_scale
            and self.dual <= eps_abs + eps_rel * self.dual_scale
            and self.complementarity <= eps_abs + eps_rel * max(self.primal_scale, self.dual_scale)
        )

    @staticmethod
    def unknown() -> KKTResiduals:
        """Residuals not computed (NaN); one shared value (the class is frozen)."""
        return _UNKNOWN


_UNKNOWN = KKTResiduals(*([float("nan")] * 7))


def kkt_residuals(
    p: QPProblem,
    x: FloatArray,
    y: FloatArray,
    z: FloatArray,
    z_box: FloatArray,
) -> KKTResiduals:
    """KKT residuals of ``(x, y, z, z_box)`` for ``p`` (see the module docstring).

    A nonzero multiplier on an infinite bound (``+-INF``) is a sign error: it shows as a
    complementarity residual ``|z|``.

    Args:
        p: the problem.
        x: primal solution (n).
        y: equality multipliers (n_eq).
        z: inequality multipliers (n_in).
        z_box: bound multipliers (n).
    """
    Hx = p.H.dot(x)
    xHx = float(x.dot(Hx))
    gx = float(p.g.dot(x))
    force = z_box.copy()  # A'y + C'z + z_box
    primal = 0.0
    primal_scale = float(np.abs(x).max(initial=0.0))
    gap = xHx + gx
    by = 0.0
    if p.n_eq:
        force += p.A.T.dot(y)
        primal = float(np.abs(p.A.dot(x) - p.b).max(initial=0.0))
        primal_scale = max(primal_scale, float(np.abs(p.b).max(initial=0.0)))
        by = float(p.b.dot(y))
        gap += by
    if p.n_in:
        force += p.C.T.dot(z)
        values = np.concatenate((p.C.dot(x), x))
        lo = np.concatenate((p.l, p.lb))
        hi = np.concatenate((p.u, p.ub))
        w = np.concatenate((z, z_box))
    else:
        values, lo, hi, w = x, p.lb, p.ub, z_box
    above = values - hi  # > 0: violated upper bound
    below = lo - values
    primal = max(primal, float(above.max(initial=0.0)), float(below.max(initial=0.0)))
    if p.n_in:
        primal_scale = max(primal_scale, float(np.abs(values[: p.n_in]).max(initial=0.0)))
    pushes_up = w > 0.0
    # slack of the bound each multiplier pushes against, times the multiplier
    comp = float(np.minimum(np.abs(w), np.abs(np.where(pushes_up, above, below))).max(initial=0.0))
    # the bound each multiplier pushes against (a zero multiplier none: inf * 0 would be NaN)
    gap += float(np.where(pushes_up, hi, np.where(w < 0.0, lo, 0.0)).dot(w))
    stationarity = Hx + p.g
    stationarity += force
    return KKTResiduals(
        primal=primal,
        dual=float(np.abs(stationarity).max(initial=0.0)),
        complementarity=comp,
        duality_gap=abs(gap),
        primal_scale=primal_scale,
        dual_scale=max(
            float(np.abs(Hx).max(initial=0.0)),
            float(np.abs(p.g).max(initial=0.0)),
            float(np.abs(force).max(initial=0.0)),
        ),
        gap_scale=max(1.0, abs(xHx), abs(gx), abs(by)),
    )


def equality_kkt_residuals(
    p: QPProblem, x: FloatArray, y: FloatArray, primal: float
) -> KKTResiduals:
    """:func:`kkt_residuals` with zero inequality and bound multipliers.

    For a point whose largest constraint violation ``primal`` is already known (the
    unconstrained shortcut). Complementarity is then exactly zero; the duality gap is
    ``|x'Hx + g'x + b'y|``.
    """
    Hx = p.H.dot(x)
    xHx = float(x.dot(Hx))
    gx = float(p.g.dot(x))
    stationarity = Hx + p.g
    gap = xHx + gx
    by = 0.0
    if p.n_eq:
        stationarity += p.A.T.dot(y)
        by = float(p.b.dot(y))
        gap += by
    return KKTResiduals(
        primal=primal,
        dual=float(_max(np.abs(stationarity))),
        complementarity=0.0,
        duality_gap=abs(gap),
        primal_scale=float(_max(np.abs(x))),
        dual_scale=max(float(_max(np.abs(Hx))), float(_max(np.abs(p.g)))),
        gap_scale=max(1.0, abs(xHx), abs(gx), abs(by)),
    )


def stacked_kkt_residuals(
    H: FloatArray,
    g: FloatArray,
    x: FloatArray,
    G: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    w: FloatArray,
) -> KKTResiduals:
    """:func:`kkt_residuals` for constraints stacked as ``lo <= [I; G] x <= hi``.

    The first ``n`` entries of ``lo``, ``hi`` and ``w`` are the bounds on ``x`` and their
    multipliers, the rest the rows of ``G`` (equalities have ``lo = hi``); this is the layout
    daqp takes and returns, so its result is checked without reshuffling. Scales: ``s_p =
    max |[x; G x]|``, ``s_d = max(|Hx|, |g|)``.
    """
    n = x.shape[0]
    Hx = H.dot(x)
    xHx = float(x.dot(Hx))
    gx = float(g.dot(x))
    stationarity = Hx + g
    stationarity += w[:n]
    stationarity += G.T.dot(w[n:])
    values = np.concatenate((x, G.dot(x)))
    above = values - hi
    below = lo - values
    pushes_up = w > 0.0
    comp = np.minimum(np.abs(w), np.abs(np.where(pushes_up, above, below)))
    gap = xHx + gx + float(np.where(pushes_up, hi, np.where(w < 0.0, lo, 0.0)).dot(w))
    return KKTResiduals(
        primal=max(0.0, float(_max(above)), float(_max(below))),
        dual=float(_max(np.abs(stationarity))),
        complementarity=float(_max(comp)),
        duality_gap=abs(gap),
        primal_scale=float(_max(np.abs(values))),
        dual_scale=max(float(_max(np.abs(Hx))), float(_max(np.abs(g)))),
        gap_scale=max(1.0, abs(xHx), abs(gx)),
    )


def least_squares_kkt_residuals(
    JZ: FloatArray, res: FloatArray, z: FloatArray, mu: float, primal: float
) -> KKTResiduals:
    """KKT residuals of ``z`` for the unconstrained level ``min 1/2 |JZ z - res|^2 + mu/2 |z|^2``.

    The QP of a hierarchy level solved in closed form (``H = JZ^T JZ + mu I``, ``g = -JZ^T
    res``, no multipliers): the dual residual is the stationarity error ``|JZ^T (JZ z - res) +
    mu z|``, complementarity is zero, the duality gap is ``|z'Hz + g'z|``. ``primal`` is the
    largest violation, at the cascade's point, of the rows the level must respect (computed by
    the caller).

    Args:
        JZ: (m, r) the level's Jacobian in the remaining freedom.
        res: (m,) the level's residual to reduce, ``r - J x`` at the level's start.
        z: (r,) the step.
        mu: the level's damping.
        primal: largest constraint violation [same units as the rows].
    """
    if z.shape[0] == 0:
        return KKTResiduals(primal, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    Hz = JZ.T.dot(JZ.dot(z))
    Hz += mu * z
    g = -JZ.T.dot(res)
    stationarity = Hz + g
    zHz = float(z.dot(Hz))
    gz = float(g.dot(z))
    return KKTResiduals(
        primal=primal,
        dual=float(_max(np.abs(stationarity))),
        complementarity=0.0,
        duality_gap=abs(zHz + gz),
        primal_scale=float(_max(np.abs(z))),
        dual_scale=max(float(_max(np.abs(Hz))), float(_max(np.abs(g)))),
        gap_scale=max(1.0, abs(zHz), abs(gz)),
    )


def box_kkt_residuals(p: QPProblem, x: FloatArray, tol: float = 1e-9) -> KKTResiduals:
    """KKT residuals of ``x`` for a QP with bounds only, multipliers recovered from ``x``.

    For a solver that returns no multipliers (the compiled box kernel): ``z_box = -(Hx + g)``
    on the components at a bound (within ``tol`` times ``max(1, |x_i|)``), zero elsewhere, so
    the dual residual is the stationarity error of the free components and a multiplier of the
    wrong sign shows in the complementarity residual (see :func:`kkt_residuals`).

    Args:
        p: the problem (its ``A`` and ``C`` must have no rows).
        x: primal solution (n).
        tol: relative distance to a bound under which a component counts as at the bound.

    Raises:
        ValueError: ``p`` has equality or inequality rows.
    """
    if p.n_eq or p.n_in:
        raise ValueError("box_kkt_residuals takes a problem with bounds only")
    at_bound = (np.abs(x - p.lb) <= tol * np.maximum(1.0, np.abs(x))) | (
        np.abs(x - p.ub) <= tol * np.maximum(1.0, np.abs(x))
    )
    z_box = np.where(at_bound, -(p.H.dot(x) + p.g), 0.0)
    return kkt_residuals(p, x, np.zeros(0), np.zeros(0), z_box)


__all__ = [
    "KKTResiduals",
    "box_kkt_residuals",
    "equality_kkt_residuals",
    "kkt_residuals",
    "least_squares_kkt_residuals",
    "stacked_kkt_residuals",
]
