"""Optional compiled kernels (C++ on Pinocchio), built by ``python -m taskspace._native.build``.

``make demo`` and ``make test`` build them. Without them, or when they were compiled against
another Pinocchio than the one imported, taskspace runs its Python implementations (same
results; see :func:`ik_kernel`, ``taskspace.ik.DifferentialIKOptions.native``,
:func:`planning_kernel` and ``taskspace.planning.RRTConnectOptions.native``).
"""

from __future__ import annotations

import functools
import importlib
from types import ModuleType

import pinocchio as pin


@functools.cache
def _load_module(name: str) -> tuple[ModuleType | None, str]:
    try:
        module = importlib.import_module(f"taskspace._native.{name}")
    except ImportError as exc:
        return None, f"{name} not built ({exc}); run 'python -m taskspace._native.build'"
    built_for = str(module.PINOCCHIO_VERSION)
    if built_for != pin.__version__:
        return None, (
            f"{name} built for Pinocchio {built_for} but {pin.__version__} is imported; "
            "rebuild with 'python -m taskspace._native.build --force'"
        )
    return module, ""


def _load() -> tuple[ModuleType | None, str]:
    return _load_module("_ik_kernel")


def ik_kernel() -> ModuleType | None:
    """The compiled weighted-IK kernel module, or ``None`` when it cannot be used."""
    return _load()[0]


def planning_kernel() -> ModuleType | None:
    """The compiled RRT-Connect and collision kernel module, or ``None`` when it cannot be used."""
    return _load_module("_planning_kernel")[0]


def status() -> str:
    """Why the kernels are not used (empty when they are all used)."""
    return "; ".join(
        reason for reason in (_load()[1], _load_module("_planning_kernel")[1]) if reason
    )
