"""time_parametrize honours the requested end path velocity (sweep35).

The controllable sets were ``[0, beta_k]`` and the forward pass stopped wherever it got: an
end path velocity beyond what the acceleration limit reaches from rest came back SUCCESS,
ending slower than asked; a jerk slowdown did the same, or made a start at ``sdot > 0``
INFEASIBLE. Reference: on the straight line q = s D the path acceleration is at most
a_s = min_i a_i / |D_i|, so from rest the end path velocity is at most sqrt(2 a_s L).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.trajopt import (
    CallablePath,
    TimeParametrizationOptions,
    TimeParametrizationStatus,
    time_parametrize,
)

D = np.array([2.0, -1.0, 0.5])
V = np.array([1.0, 1.0, 1.0])
A = np.array([2.0, 2.0, 2.0])


def _line(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.asarray(s)
    return s[:, None] * D, np.tile(D, (len(s), 1)), np.zeros((len(s), 3))


PATH = CallablePath(_line, 0.0, 1.0)


@pytest.mark.parametrize(("end", "reachable"), [(1.4, True), (1.5, False), (3.0, False)])
def test_unreachable_end_velocity_is_infeasible(end: float, reachable: bool) -> None:
    limit = math.sqrt(2.0 * min(A / np.abs(D)) * 1.0)  # sqrt(2): from rest over L = 1
    assert reachable == (end <= limit)
    opts = TimeParametrizationOptions(grid_points=200, end_path_velocity=end)
    r = time_parametrize(PATH, 100.0, A, options=opts)  # the velocity limit does not bind
    if reachable:
        assert r.status is TimeParametrizationStatus.SUCCESS
        assert r.s_dot[-1] == pytest.approx(end, rel=1e-9)
    else:
        assert r.status is TimeParametrizationStatus.INFEASIBLE
        assert not r.success


@pytest.mark.parametrize(("start", "end"), [(0.0, 0.3), (0.3, 0.0), (0.1, 0.0)])
def test_jerk_slowdown_keeps_the_end_velocities(start: float, end: float) -> None:
    opts = TimeParametrizationOptions(
        grid_points=200, start_path_velocity=start, end_path_velocity=end
    )
    assert time_parametrize(PATH, V, A, options=opts).success  # feasible without the jerk
    r = time_parametrize(PATH, V, A, max_jerk=7.0, options=opts)
    # the heuristic may not meet the jerk limit, but what it returns keeps the requested
    # end velocities and the velocity and acceleration limits
    assert r.status is not TimeParametrizationStatus.INFEASIBLE
    np.testing.assert_allclose(r.s_dot[[0, -1]], [start, end], rtol=1e-9, atol=1e-12)
    assert np.all(np.abs(r.qd) <= V * (1 + 1e-9))
    assert np.all(np.abs(r.qdd) <= A * (1 + 1e-9))
    if r.status is TimeParametrizationStatus.SUCCESS:
        assert np.all(np.abs(r.qddd) <= 7.0 * (1 + 1e-5))
