"""Stability of linear systems by eigenvalues.

Continuous time ``x' = A x``: asymptotically stable iff every eigenvalue has ``Re < 0``
(spectral abscissa < 0). Discrete time ``x+ = A x``: iff every eigenvalue has ``|lambda| < 1``
(spectral radius < 1).

Thread safety: the functions keep their state local to the call; a :class:`StabilityResult` is
plain result data, not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace.control._linear import square


@dataclass
class StabilityResult:
    """Result of :func:`stability`.

    Attributes:
        stable: asymptotically stable (with the requested margin).
        eigenvalues: eigenvalues of ``A`` (complex).
        discrete: discrete-time test.
        spectral_abscissa: ``max Re lambda`` [1/s] (continuous).
        spectral_radius: ``max |lambda|`` (discrete).
        margin: the margin used: ``max Re lambda < -margin`` or ``max |lambda| < 1 - margin``.
    """

    stable: bool
    eigenvalues: np.ndarray
    discrete: bool
    spectral_abscissa: float
    spectral_radius: float
    margin: float


def stability(A: Any, *, discrete: bool = False, margin: float = 0.0) -> StabilityResult:
    """Eigenvalue stability test of ``x' = A x`` or ``x+ = A x``.

    Args:
        A: system matrix (n x n).
        discrete: discrete-time system.
        margin: required distance from the stability boundary (>= 0).
    """
    A = square(A, "A")
    from taskspace._validation import check_positive

    margin = check_positive(margin, "margin", strict=False)
    eig = np.linalg.eigvals(A) if A.size else np.zeros(0, dtype=complex)
    abscissa = float(np.max(eig.real)) if eig.size else -np.inf
    radius = float(np.max(np.abs(eig))) if eig.size else 0.0
    stable = radius < 1.0 - margin if discrete else abscissa < -margin
    return StabilityResult(
        stable=bool(stable),
        eigenvalues=eig,
        discrete=discrete,
        spectral_abscissa=abscissa,
        spectral_radius=radius,
        margin=margin,
    )


def is_stable(A: Any, *, discrete: bool = False, margin: float = 0.0) -> bool:
    """Whether ``x' = A x`` (or ``x+ = A x``) is asymptotically stable (see :func:`stability`)."""
    return stability(A, discrete=discrete, margin=margin).stable
