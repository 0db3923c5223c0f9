"""Collision and distance requests without a cached GJK guess (one place for every query).

Pinocchio's ``GeometryData`` requests keep coal's cached GJK guess: each pair's narrow phase
starts from the support directions of its previous call. When that call was at a far
configuration, coal can answer "free" for a real penetration (MotionBenchMaker
bookshelf_small problem 1: ``panda_link5`` 1.3 cm inside ``shelf_bottom`` reported free after a
call of that pair at another configuration). The ``GeometryData`` of ``Robot``'s queries, of
``State``'s distances, of ``CollisionChecker`` (its data and pools) and of ``certify_path``
go through :func:`without_cached_guess` (lazily, at their first query: it costs about 0.5 ms
for 156 pairs), so each query starts from coal's default guess and its answer does not
depend on earlier calls. The collision requests also get ``enable_contact`` (coal runs EPA
when GJK finds a collision): without it, coal 3.0.3 compares GJK's last distance, anything up
to GJK's 1e-6 tolerance, with a 1e-12 threshold and reported a 3.5 cm overlap free (the
compiled kernel sets the threshold to the tolerance instead). The compiled planning kernel
does the same on its own copy. Not
covered: the compiled IK kernel's distance data (distances only; with the cached guess they
differed from a tight-tolerance reference by at most 0.05-0.11 mm in our measurements).
"""

from __future__ import annotations

import warnings
from typing import Any

import coal

__all__ = ["without_cached_guess"]


def _reset(request: Any) -> None:
    request.gjk_initial_guess = coal.GJKInitialGuess.DefaultGuess
    request.enable_cached_gjk_guess = False  # deprecated in coal 3, still read by coal


def without_cached_guess(geometry_data: Any) -> Any:
    """Turn the cached GJK guess off in every request of ``geometry_data`` (in place).

    Args:
        geometry_data: a ``pin.GeometryData`` (its ``collisionRequests`` and
            ``distanceRequests`` are modified).

    Returns:
        ``geometry_data`` itself, so that ``without_cached_guess(geom.createData())`` works.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for request in geometry_data.collisionRequests:
            _reset(request)
            # EPA on GJK's "Collision": without it coal compares GJK's last distance (up to
            # its 1e-6 tolerance) with a 1e-12 threshold and may call a deep overlap free
            # (cage: panda_hand_0 3.5 cm inside a wall; test_planning_sphere_checker.py)
            request.enable_contact = True
        for request in geometry_data.distanceRequests:
            _reset(request)
    return geometry_data
