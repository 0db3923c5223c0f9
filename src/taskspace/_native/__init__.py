"""Optional compiled kernels (C++ on Pinocchio), built by ``pip install`` (CMakeLists.txt).

``pip install .``, ``pip wheel .`` and ``make`` (``pip install --no-build-isolation -e .``)
compile them with scikit-build-core against the Pinocchio, coal and eigenpy found by CMake;
the versions found are recorded in ``_build_info.json`` next to the modules. A kernel is
imported only when the libraries imported at run time are those it was built against
(:func:`mismatches`): a kernel compiled for another Pinocchio or coal would read their
objects with another layout. Otherwise, or when the kernels are not built, taskspace runs its
Python implementations (same results; see :func:`ik_kernel`,
``taskspace.ik.DifferentialIKOptions.native``, :func:`idqp_kernel`,
``taskspace.control.InverseDynamicsOptions.native``, :func:`planning_kernel` and
``taskspace.planning.RRTConnectOptions.native``), logs a warning, and ``taskspace info``
shows the reason.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import json
import logging
import sys
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path
from types import ModuleType

import pinocchio as pin

logger = logging.getLogger(__name__)

BUILD_INFO = "_build_info.json"
"""File written by CMake next to the kernels: the library versions they were built against."""

KERNELS = ("_ik_kernel", "_idqp_kernel", "_planning_kernel")
"""Module names of the kernels."""

CHECKED = ("pinocchio", "coal", "eigenpy", "boost", "numpy", "python")
"""Libraries whose run-time version must match the build (see :func:`mismatches`)."""

REBUILD = (
    "rebuild the kernels in this environment: 'make native' in a checkout, or "
    "'pip install --no-build-isolation --force-reinstall --no-deps <taskspace source>'"
)


def _distribution_version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return ""


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return ""


def runtime_versions() -> dict[str, str]:
    """Versions of the libraries imported by this process (keys of :data:`CHECKED`, ``cpu``).

    Boost is the version of the ``cmeel-boost`` wheel ("" when Boost comes from elsewhere,
    and it is then not compared); ``cpu`` is the processor model (compared only for kernels
    built with ``TASKSPACE_NATIVE_ARCH``).
    """
    import coal
    import eigenpy
    import numpy as np

    return {
        "pinocchio": str(pin.__version__),
        "coal": str(coal.__version__),
        "eigenpy": str(eigenpy.__version__),
        "boost": _distribution_version("cmeel-boost"),
        "numpy": str(np.__version__),
        "python": f"{sys.version_info.major}.{sys.version_info.minor}",
        "cpu": _cpu_model(),
    }


def _release(version: str, parts: int) -> tuple[str, ...]:
    return tuple(version.split(".")[:parts])


def mismatches(built: Mapping[str, str], running: Mapping[str, str]) -> list[str]:
    """Differences between the build record of a kernel and the running libraries.

    Pinocchio, coal and eigenpy must be the same release (``major.minor.patch``): the kernels
    use their classes' memory layout and their shared libraries. Boost likewise (Boost.Python
    and Boost's containers are in the interfaces), when the running Boost is known. NumPy must
    have the same major version (its C ABI changes only there), Python the same
    ``major.minor``. A kernel built with ``-march=native`` must run on the processor model it
    was built on.

    Args:
        built: the build record (``_build_info.json``).
        running: :func:`runtime_versions`.

    Returns:
        One ``"<library> <built> (built against) != <running> (imported)"`` line per
        difference; empty when the kernel can be used.
    """
    rules = {"pinocchio": 3, "coal": 3, "eigenpy": 3, "boost": 3, "numpy": 1, "python": 2}
    problems = []
    for name, parts in rules.items():
        have = running.get(name, "")
        want = built.get(name, "")
        if name == "boost" and not have:
            continue
        if not want or _release(want, parts) != _release(have, parts):
            problems.append(
                f"{name} {want or '(not recorded)'} (built against) != "
                f"{have or '(unknown)'} (imported)"
            )
    if built.get("arch") == "native" and built.get("cpu", "") != running.get("cpu", ""):
        problems.append(
            f"built with -march=native on '{built.get('cpu')}', running on '{running.get('cpu')}'"
        )
    return problems


def build_info_path(name: str) -> Path | None:
    """Where the build record of kernel ``name`` is (``None`` when the kernel is not built).

    In an editable install whose sources changed, finding the kernel rebuilds it first.
    """
    spec = importlib.util.find_spec(f"taskspace._native.{name}")
    if spec is None or spec.origin is None:
        return None
    return Path(spec.origin).with_name(BUILD_INFO)


def read_build_info(path: Path) -> dict[str, str]:
    """The build record at ``path`` (empty when missing or unreadable)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return {str(k): str(v) for k, v in data.items()} if isinstance(data, dict) else {}


def build_info() -> dict[str, str]:
    """The build record of the kernels (empty when they are not built)."""
    try:
        path = build_info_path(KERNELS[0])
    except Exception:  # a failed rebuild of an editable install
        return {}
    return read_build_info(path) if path is not None else {}


@functools.cache
def _load_module(name: str) -> tuple[ModuleType | None, str]:
    try:
        path = build_info_path(name)
    except Exception as exc:  # a failed rebuild of an editable install
        return _refuse(name, f"{name} could not be rebuilt ({exc})")
    if path is None:
        return None, f"{name} not built (pip install the taskspace sources, or 'make native')"
    built = read_build_info(path)
    if not built:
        return _refuse(name, f"{name} has no build record {path}; {REBUILD}")
    problems = mismatches(built, runtime_versions())
    if problems:
        return _refuse(name, f"{name} not loaded: {'; '.join(problems)}; {REBUILD}")
    try:
        module = importlib.import_module(f"taskspace._native.{name}")
    except ImportError as exc:
        return _refuse(name, f"{name} cannot be imported ({exc}); {REBUILD}")
    return module, ""


def _refuse(name: str, reason: str) -> tuple[None, str]:
    logger.warning("compiled kernel not used, Python path instead: %s", reason)
    return None, reason


def ik_kernel() -> ModuleType | None:
    """The compiled weighted-IK kernel module, or ``None`` when it cannot be used."""
    return _load_module("_ik_kernel")[0]


def idqp_kernel() -> ModuleType | None:
    """The compiled inverse-dynamics QP kernel module, or ``None`` when it cannot be used."""
    return _load_module("_idqp_kernel")[0]


def planning_kernel() -> ModuleType | None:
    """The compiled RRT-Connect and collision kernel module, or ``None`` when it cannot be used."""
    return _load_module("_planning_kernel")[0]


def status() -> str:
    """Why the kernels are not used (empty when they are all used)."""
    return "; ".join(reason for reason in (_load_module(n)[1] for n in KERNELS) if reason)
