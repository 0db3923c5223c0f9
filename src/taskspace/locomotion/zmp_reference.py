"""The ZMP reference of a footstep plan and the support polygon at each instant.

In single support the reference ZMP sits at the center of the stance foot; in double support
it moves linearly from the center of the foot it leaves to the center of the foot it goes to
(at the start from the middle of the feet, at the end back to it). The support polygon is
the stance sole in single support and the convex hull of both soles in double support.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    check_finite,
    check_positive,
)
from taskspace.locomotion.footsteps import FootstepPlan, Phase, check_plan
from taskspace.locomotion.support_polygon import SupportPolygon


@dataclass(frozen=True, kw_only=True)
class SoleSize:
    """Rectangular sole used for the support polygons of a footstep plan.

    Attributes:
        length: along the foot's x axis [m].
        width: along the foot's y axis [m].
    """

    length: float = 0.2
    width: float = 0.1

    def __post_init__(self) -> None:
        check_positive(self.length, "length")
        check_positive(self.width, "width")


def _phase_index(phases: list[Phase], t: FloatArray) -> np.ndarray:
    ends = np.array([p.end for p in phases])
    return np.minimum(np.searchsorted(ends, t, side="right"), len(phases) - 1)


def _phases(plan: Any) -> list[Phase]:
    """The phases of ``plan`` (checked to be a :class:`FootstepPlan`)."""
    return check_plan(plan).phases()


def _times(times: Any) -> FloatArray:
    """``times`` [s] as a finite flat float array (a NaN time has no phase)."""
    t = as_float_array(times, "times").ravel()
    check_finite(t, "times")
    return t


def zmp_reference(plan: FootstepPlan, times: Any) -> FloatArray:
    """(T, 2) reference ZMP [m] at ``times`` [s] (held at its final value after the end)."""
    t = _times(times)
    phases = _phases(plan)
    idx = _phase_index(phases, t)
    out = np.empty((t.size, 2))
    for k, ph in enumerate(phases):
        sel = idx == k
        if not sel.any():
            continue
        s = np.clip((t[sel] - ph.start) / (ph.end - ph.start), 0.0, 1.0)[:, None]
        out[sel] = (1 - s) * ph.zmp_start + s * ph.zmp_end
    return out


def support_polygon_at(
    plan: FootstepPlan, t: float, sole: SoleSize | None = None
) -> SupportPolygon:
    """The support polygon at time ``t`` [s]."""
    sole = sole or SoleSize()
    phases = _phases(plan)
    ph = phases[int(_phase_index(phases, np.array([as_scalar(t, "t")]))[0])]
    pts = np.vstack([f.sole_corners(sole.length, sole.width) for f in ph.stance])
    return SupportPolygon.from_points(pts)


def support_polygons(
    plan: FootstepPlan, times: Any, sole: SoleSize | None = None
) -> list[SupportPolygon]:
    """Support polygons at ``times`` (one polygon object per phase, shared)."""
    sole = sole or SoleSize()
    t = _times(times)
    phases = _phases(plan)
    polys = [
        SupportPolygon.from_points(
            np.vstack([f.sole_corners(sole.length, sole.width) for f in ph.stance])
        )
        for ph in phases
    ]
    return [polys[int(i)] for i in _phase_index(phases, t)]
