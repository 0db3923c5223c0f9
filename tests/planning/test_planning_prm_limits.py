"""PRM keeps its limits (issue #22 audit, stop 23).

:func:`build_prm` drew all ``max_iterations`` samples at once and :func:`prm_query` attached
start and goal with no deadline: ``max_iterations=10**5, time_limit_s=0.3`` ran 55 s on the
ur5, ``10**8`` raised numpy's MemoryError and ``10**12`` had the process OOM-killed. Now the
roadmap grows in rounds under the deadline and a size that cannot fit is refused when no time
limit bounds it.

The clock is simulated: every configuration the checker evaluates advances it by ``COST_S``,
so a deadline is crossed after a known amount of work, whatever the machine's load. The huge
counts run in a subprocess with an address-space limit and a timeout (a regression allocates).
"""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import taskspace
from taskspace.errors import InvalidInputError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import build_lazy_prm
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query

COST_S = 1e-4  # simulated seconds per configuration checked
RES = 0.01
SRC = str(Path(taskspace.__file__).resolve().parents[1])


def _wall(q: np.ndarray) -> np.ndarray:
    """The unit square with a wall at x = 0.5 open above y = 0.8."""
    return np.asarray(~((np.abs(q[:, 0] - 0.5) < 0.03) & (q[:, 1] < 0.8)))


class _Clocked:
    """A 2-D space whose checker advances a simulated clock; logs (clock, rows) per query."""

    def __init__(self) -> None:
        self.clock = 100.0
        self.calls: list[tuple[float, int]] = []
        self.space = ConfigurationSpace(
            np.zeros(2),
            np.ones(2),
            FunctionChecker(self._check),
            edge=EdgeCheckOptions(resolution=RES),
        )

    def _check(self, q: np.ndarray) -> np.ndarray:
        self.calls.append((self.clock, q.shape[0]))
        self.clock += COST_S * q.shape[0]
        return _wall(q)

    def read(self) -> float:
        return self.clock

    def late_rows(self, deadline: float) -> int:
        """Configurations of the queries that started after the deadline."""
        return sum(n for t, n in self.calls if t > deadline)


_CHILD = textwrap.dedent(
    """
    import json, resource, sys, time
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
    sys.meta_path[:] = [f for f in sys.meta_path
                        if type(f).__name__ != "ScikitBuildRedirectingFinder"]
    sys.path.insert(0, {src!r})
    import numpy as np
    from taskspace.errors import InvalidInputError
    from taskspace.planning.collision_checker import FunctionChecker
    from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
    from taskspace.planning.prm import PRMOptions, prm
    clock = [100.0]
    def free(q):
        clock[0] += {cost!r} * q.shape[0]
        return ~((np.abs(q[:, 0] - 0.5) < 0.03) & (q[:, 1] < 0.8))
    time.perf_counter = lambda: clock[0]
    space = ConfigurationSpace(np.zeros(2), np.ones(2), FunctionChecker(free),
                               edge=EdgeCheckOptions(resolution={res!r}))
    out = []
    for n, limit in {cases!r}:
        t0 = clock[0]
        try:
            res, roadmap = prm(space, [0.1, 0.1], [0.9, 0.1],
                               PRMOptions(max_iterations=n, time_limit_s=limit))
            out.append([res.status.value, roadmap.size, roadmap.timed_out, clock[0] - t0])
        except InvalidInputError as e:
            out.append(["refused", str(e)])
    print(json.dumps(out))
    """
)


def _run_child(cases: list[tuple[int, float | None]]) -> list[list[object]]:
    code = _CHILD.format(src=SRC, cost=COST_S, res=RES, cases=cases)
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return list(json.loads(done.stdout.strip().splitlines()[-1]))


def test_huge_max_iterations_stop_at_the_time_limit_or_are_refused() -> None:
    """10**8 and 10**12 samples with 0.3 s stop at the deadline (a few thousand simulated
    configurations), without a time limit they are refused before anything is allocated."""
    limit = 0.3
    out = _run_child([(10**8, limit), (10**12, limit), (10**8, None), (10**12, None)])
    for status, size, timed_out, spent in out[:2]:  # type: ignore[misc]
        assert status == "time_limit" and timed_out
        assert 0 < size < limit / COST_S  # the nodes sampled and connected in 0.3 s
        # one batch of candidates or one edge after the deadline at most
        assert spent <= limit + 256 * COST_S + 1e-9
    for row in out[2:]:
        assert row[0] == "refused" and "GiB" in str(row[1]), row


def test_build_reads_the_clock_before_each_batch_and_edge(monkeypatch: pytest.MonkeyPatch) -> None:
    world = _Clocked()
    monkeypatch.setattr(time, "perf_counter", world.read)
    t0 = world.clock
    roadmap = build_prm(world.space, PRMOptions(max_iterations=100_000, time_limit_s=0.5))
    deadline = t0 + 0.5
    assert roadmap.timed_out
    assert 500 <= roadmap.size < 100_000  # the first round was connected in time
    assert world.late_rows(deadline) == 0  # nothing starts after the deadline
    assert world.clock <= deadline + 256 * COST_S + 1e-9  # overrun: one batch or one edge


def test_query_reads_the_clock_while_attaching(monkeypatch: pytest.MonkeyPatch) -> None:
    """prm_query's start/goal connections stop at its time limit (they had no deadline)."""
    world = _Clocked()
    roadmap = build_prm(world.space, PRMOptions(max_iterations=300, k_neighbors=40, seed=3))
    monkeypatch.setattr(time, "perf_counter", world.read)
    world.calls.clear()
    t0 = world.clock
    limit = 60 * COST_S  # less than the attach's 80 edges need
    opts = PRMOptions(max_iterations=300, k_neighbors=40, time_limit_s=limit)
    result = prm_query(world.space, roadmap, [0.1, 0.1], [0.9, 0.1], opts)
    assert result.status.value == "time_limit" and not result.success
    deadline = t0 + limit
    assert world.late_rows(deadline) == 0
    assert world.clock <= deadline + world.space.edge.max_batch * COST_S + 1e-9


def test_rounds_connect_every_node_to_its_k_nearest() -> None:
    """Enumeration: with 1300 nodes and a time limit (rounds of 500, 500, 300) every new
    node's k nearest among the nodes so far are tried and joined exactly when the segment is
    free (at the space's resolution, the points ``i / n``); without a time limit, the k-NN
    graph of all the nodes (slide 3:31)."""
    space = ConfigurationSpace(
        np.zeros(2), np.ones(2), FunctionChecker(_wall), edge=EdgeCheckOptions(resolution=RES)
    )
    k = 6
    opts = PRMOptions(max_iterations=1300, k_neighbors=k, seed=5, time_limit_s=1e6)
    roadmap = build_prm(space, opts)  # a time limit: rounds
    whole = build_prm(space, PRMOptions(max_iterations=1300, k_neighbors=k, seed=5))
    assert roadmap.size == whole.size == 1300 and not roadmap.timed_out
    nodes = roadmap.nodes

    def free(i: int, j: int) -> bool:
        n = max(1, math.ceil(np.linalg.norm(nodes[j] - nodes[i]) / RES - 1e-12))
        t = (np.arange(n + 1) / n)[:, None]  # the space's resolution: its points
        return bool(_wall(nodes[i] + t * (nodes[j] - nodes[i])).all())

    def knn_pairs(rounds: list[tuple[int, int]]) -> set[tuple[int, int]]:
        out: set[tuple[int, int]] = set()
        for lo, hi in rounds:
            d = np.linalg.norm(nodes[:hi, None, :] - nodes[None, :hi, :], axis=2)
            np.fill_diagonal(d, np.inf)
            for i in range(lo, hi):  # every new node's k nearest among the nodes so far
                for j in np.argsort(d[i], kind="stable")[:k].tolist():
                    out.add((min(i, j), max(i, j)))
        return out

    rounds = knn_pairs([(0, 500), (500, 1000), (1000, 1300)])
    assert {(int(i), int(j)) for i, j in roadmap.edges} == {e for e in rounds if free(*e)}
    # without a time limit: one round, the k-NN graph of all the nodes
    nodes = whole.nodes
    one = knn_pairs([(0, 1300)])
    assert {(int(i), int(j)) for i, j in whole.edges} == {e for e in one if free(*e)}
    nodes = roadmap.nodes
    edges = {(int(i), int(j)) for i, j in roadmap.edges}
    costs = {(i, j): c for i, nb in enumerate(roadmap.adjacency) for j, c in nb}
    for i, j in itertools.islice(edges, 200):
        assert costs[(i, j)] == pytest.approx(float(np.linalg.norm(nodes[i] - nodes[j])))


def test_an_empty_roadmap_and_a_refused_size() -> None:
    space = ConfigurationSpace(
        np.zeros(2), np.ones(2), FunctionChecker(_wall), edge=EdgeCheckOptions(resolution=RES)
    )
    empty = build_prm(space, PRMOptions(max_iterations=0))
    assert empty.size == 0 and not empty.timed_out
    with pytest.raises(InvalidInputError, match="GiB"):
        build_prm(space, PRMOptions(max_iterations=10**11))
    with pytest.raises(InvalidInputError, match="GiB"):  # it drew them all at once too
        build_lazy_prm(space, PRMOptions(max_iterations=10**11))
    result, _ = prm(space, [0.1, 0.9], [0.9, 0.9], PRMOptions(max_iterations=0))
    assert result.success and result.path.shape == (2, 2)  # the straight line, no sample
