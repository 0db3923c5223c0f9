"""Optional compiled kernels (C++ on Pinocchio), built by ``python -m taskspace._native.build``.

``make demo`` and ``make test`` build them. Without them, or when they were compiled against
another Pinocchio than the one imported, taskspace runs its Python implementations (same
results; see :func:`ik_kernel` and ``taskspace.ik.DifferentialIKOptions.native``).
"""

from __future__ import annotations

import functools
from types import ModuleType

import pinocchio as pin


@functools.cache
def _load() -> tuple[ModuleType | None, str]:
    try:
        from taskspace._native import _ik_kernel  # type: ignore[attr-defined]
    except ImportError as exc:
        return None, f"not built ({exc}); run 'python -m taskspace._native.build'"
    built_for = str(_ik_kernel.PINOCCHIO_VERSION)
    if built_for != pin.__version__:
        return None, (
            f"built for Pinocchio {built_for} but {pin.__version__} is imported; "
            "rebuild with 'python -m taskspace._native.build --force'"
        )
    return _ik_kernel, ""


def ik_kernel() -> ModuleType | None:
    """The compiled weighted-IK kernel module, or ``None`` when it cannot be used."""
    return _load()[0]


def status() -> str:
    """Why the kernels are not used (empty when they are)."""
    return _load()[1]
