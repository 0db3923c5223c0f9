"""PRM* keeps its time limit when collision checks are costly (a batch's edges were checked
in chunks of 256 without a look at the clock: 3.9 s for a 1 s limit on Talos).

The clock is simulated: ``time.perf_counter`` advances by a fixed cost per configuration the
checker evaluates, so the overrun is counted deterministically, not timed.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.prm_star import PRMStarOptions, prm_star

COST_S = 1e-4  # simulated seconds per checked configuration


@pytest.mark.parametrize("limit", [0.5, 1.0])
def test_prm_star_overruns_its_limit_by_little_with_costly_checks(
    monkeypatch: pytest.MonkeyPatch, limit: float
) -> None:
    clock = [1000.0]

    def fake_clock() -> float:
        return clock[0]

    evaluated = [0]

    def free(q: np.ndarray) -> np.ndarray:
        clock[0] += COST_S * q.shape[0]
        evaluated[0] += q.shape[0]  # (first_invalid counts rows up to the first invalid one)
        return ~((q[:, 0] > 0.4) & (q[:, 0] < 0.6) & (q[:, 1] < 0.8))

    space = ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=0.002)
    )
    monkeypatch.setattr(time, "perf_counter", fake_clock)
    opts = PRMStarOptions(time_limit_s=limit, max_iterations=None, seed=0)
    res, _ = prm_star(space, [0.1, 0.5], [0.9, 0.5], opts)
    assert res.log["stopped_by"] == "time"
    assert evaluated[0] * COST_S >= limit  # the clock was driven by the checks
    # a batch of samples (100 x 1e-4 s) plus a chunk sized to limit / 50 at most
    assert res.time_s <= limit * 1.1
