"""The compiled kernels' build record: written by CMake, checked before import.

A kernel built against other Pinocchio/coal/eigenpy/Boost/NumPy/Python versions than those
imported is refused (simulated by editing a copy of the recorded versions) and the Python
paths run instead, with a logged warning and the reason in ``taskspace info``.
"""

from __future__ import annotations

import json
import logging
import os
import sys
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path

import coal
import eigenpy
import numpy as np
import pinocchio as pin
import pytest

from taskspace import _native
from taskspace.cli import main
from taskspace.features import FramePose, JointConfiguration
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.tasks import Task

BUILT = bool(_native.build_info())
needs_kernels = pytest.mark.skipif(
    not BUILT and not os.environ.get("TASKSPACE_REQUIRE_NATIVE"), reason="kernels not built"
)


@pytest.fixture
def fresh_loader() -> Iterator[None]:
    """The loader decides again (its answer is cached per process) before and after a test."""
    _native._load_module.cache_clear()
    yield
    _native._load_module.cache_clear()


@needs_kernels
def test_record_names_the_libraries_imported_now() -> None:
    info = _native.build_info()
    assert info["pinocchio"] == pin.__version__
    assert info["coal"] == coal.__version__
    assert info["eigenpy"] == eigenpy.__version__
    assert info["boost"] == metadata.version("cmeel-boost")
    assert info["numpy"].split(".")[0] == np.__version__.split(".")[0]
    assert info["python"] == f"{sys.version_info.major}.{sys.version_info.minor}"
    assert info["arch"] in ("portable", "native")
    assert _native.mismatches(info, _native.runtime_versions()) == []
    assert _native.ik_kernel() is not None and _native.planning_kernel() is not None
    assert _native.idqp_kernel() is not None  # proxsuite is a build requirement


RUNNING = {
    "pinocchio": "4.1.0",
    "coal": "3.0.3",
    "eigenpy": "3.13.0",
    "boost": "1.90.0",
    "numpy": "2.4.6",
    "python": "3.11",
    "cpu": "AMD EPYC",
}


@pytest.mark.parametrize(
    ("key", "built", "refused"),
    [
        ("pinocchio", "4.1.1", True),
        ("pinocchio", "3.4.0", True),
        ("coal", "3.0.2", True),
        ("eigenpy", "3.12.0", True),
        ("boost", "1.89.0", True),
        ("numpy", "2.3.0", False),  # same C ABI within a major version
        ("numpy", "1.26.4", True),
        ("python", "3.12", True),
        ("pinocchio", "", True),  # a record without the version
    ],
)
def test_each_difference_is_refused_by_its_rule(key: str, built: str, refused: bool) -> None:
    record = dict(RUNNING, arch="portable")
    record[key] = built
    problems = _native.mismatches(record, RUNNING)
    assert bool(problems) == refused
    if refused:
        assert problems == [
            f"{key} {built or '(not recorded)'} (built against) != {RUNNING[key]} (imported)"
        ]


def test_native_arch_kernels_run_only_on_their_processor() -> None:
    other_cpu = dict(RUNNING, cpu="Intel Xeon")
    assert _native.mismatches(dict(RUNNING, arch="portable"), other_cpu) == []
    assert _native.mismatches(dict(RUNNING, arch="native"), RUNNING) == []
    (problem,) = _native.mismatches(dict(RUNNING, arch="native"), other_cpu)
    assert "-march=native on 'AMD EPYC', running on 'Intel Xeon'" in problem
    # Boost from another distribution than cmeel: not compared
    assert _native.mismatches(dict(RUNNING, arch="portable"), dict(RUNNING, boost="")) == []


@needs_kernels
def test_kernel_with_edited_record_is_refused_and_python_runs(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
    capsys: pytest.CaptureFixture[str],
    fresh_loader: None,
    robot_loader,  # type: ignore[no-untyped-def]
) -> None:
    record = _native.build_info()
    edited = dict(record, coal="0.0.1", pinocchio="9.9.9")
    copy = tmp_path / _native.BUILD_INFO
    copy.write_text(json.dumps(edited))
    monkeypatch.setattr(_native, "build_info_path", lambda name: copy)

    robot = robot_loader("panda")
    state = robot.state(robot.q_default)
    tcp = Task(FramePose(robot, "panda_hand_tcp"))
    tcp.set_target(
        state.frame_placement(robot.frame_id("panda_hand_tcp"))
        * pin.SE3(np.eye(3), np.array([0.0, 0.1, 0.0]))
    )
    tasks = [tcp, Task(JointConfiguration(robot), robot.q_default, weight=1e-3)]
    with caplog.at_level(logging.WARNING, logger="taskspace._native"):
        ik = DifferentialIK(robot, tasks)
        assert not ik.native  # the kernel is refused: Python path
    assert _native.ik_kernel() is None and _native.planning_kernel() is None
    assert _native.idqp_kernel() is None
    expected = (
        f"pinocchio 9.9.9 (built against) != {pin.__version__} (imported); "
        f"coal 0.0.1 (built against) != {coal.__version__} (imported)"
    )
    assert expected in _native.status()
    assert "make native" in _native.status()
    assert any(expected in r.getMessage() for r in caplog.records)

    step = ik.solve(state, 0.01)
    python = DifferentialIK(robot, tasks, options=DifferentialIKOptions(native=False))
    reference = python.solve(state, 0.01)
    assert step.success and step.qp.backend == reference.qp.backend != "native"
    np.testing.assert_array_equal(step.dq, reference.dq)

    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert out.count("not in use") == 3 and expected in out

    # the real record again: loaded
    monkeypatch.undo()
    _native._load_module.cache_clear()
    assert _native.ik_kernel() is not None and _native.status() == ""


@needs_kernels
def test_kernel_without_record_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fresh_loader: None
) -> None:
    monkeypatch.setattr(_native, "build_info_path", lambda name: tmp_path / "missing.json")
    assert _native.planning_kernel() is None
    assert f"_planning_kernel has no build record {tmp_path / 'missing.json'}" in _native.status()


def test_kernel_not_built_is_reported(monkeypatch: pytest.MonkeyPatch, fresh_loader: None) -> None:
    monkeypatch.setattr(_native, "build_info_path", lambda name: None)
    assert _native.ik_kernel() is None
    assert "_ik_kernel not built" in _native.status()
