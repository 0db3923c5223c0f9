"""Linear-quadratic regulators (infinite horizon), continuous and discrete time.

Continuous: minimize ``int_0^inf x^T Q x + u^T R u dt`` subject to ``x' = A x + B u``:
``u = -K x``, ``K = R^-1 B^T P`` with ``P`` the stabilizing solution of the CARE.
Discrete: minimize ``sum_k x_k^T Q x_k + u_k^T R u_k`` subject to ``x+ = A x + B u``:
``K = (R + B^T P B)^-1 B^T P A`` with ``P`` the stabilizing solution of the DARE.

Thread safety: the functions keep their state local to the call; :class:`LQROptions` and
:class:`LQRStatus` are immutable; an :class:`LQRResult` is plain result data (arrays), not locked:
do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_matrix
from taskspace.control._linear import symmetric_psd, system
from taskspace.control.controllability import controllability
from taskspace.control.riccati import (
    RiccatiOptions,
    RiccatiResult,
    solve_continuous_riccati,
    solve_discrete_riccati,
)
from taskspace.errors import InvalidInputError


class LQRStatus(enum.Enum):
    """Outcome of an LQR design."""

    SOLVED = "solved"
    """Stabilizing gain found."""
    NOT_CONVERGED = "not_converged"
    """The Riccati iteration stopped early; ``K`` comes from its last iterate."""


@dataclass(frozen=True, kw_only=True)
class LQROptions:
    """Settings of :func:`lqr` and :func:`dlqr`.

    Attributes:
        require_controllable: reject uncontrollable pairs (``False``: accept stabilizable
            pairs, whose uncontrollable modes are already stable).
        controllability_tolerance: relative rank threshold (see ``controllability``).
        riccati: options of the Riccati solver.
    """

    require_controllable: bool = True
    controllability_tolerance: float | None = None
    riccati: RiccatiOptions = field(default_factory=RiccatiOptions)


@dataclass
class LQRResult:
    """An LQR design.

    Attributes:
        success: ``K`` is the optimal stabilizing gain.
        status: see :class:`LQRStatus`.
        K: feedback gain, ``u = -K x`` (m x n).
        P: Riccati solution (n x n); the optimal cost from ``x0`` is ``x0^T P x0``.
        closed_loop_eigenvalues: eigenvalues of ``A - B K`` (complex).
        stable: the closed loop is asymptotically stable.
        discrete: discrete-time design.
        riccati: the Riccati solve.
        solve_time: wall time [s].
    """

    success: bool
    status: LQRStatus
    K: FloatArray
    P: FloatArray
    closed_loop_eigenvalues: np.ndarray
    stable: bool
    discrete: bool
    riccati: RiccatiResult
    solve_time: float


def _check_pair(A: FloatArray, B: FloatArray, options: LQROptions, discrete: bool) -> None:
    """Refuse an uncontrollable (or, when allowed, unstabilizable) pair.

    The test runs on ``(2^-e A, B)`` with ``2^e`` the power of two nearest ``max |A|``
    (exact; the Krylov columns ``A^k B`` only change scale, the PBH modes are scaled back):
    the controllability matrix of a 3-state ``A`` near 1e200 overflowed (``A^2 B ~ 1e400``)
    and the pair was refused "the controllability matrix overflows" whatever its rank.
    """
    top = float(np.max(np.abs(A)))
    e = math.frexp(top)[1] if top > 0 else 0
    report = controllability(np.ldexp(A, -e) if e else A, B, options.controllability_tolerance)
    if report.controllable:
        return
    report.uncontrollable_modes = np.ldexp(report.uncontrollable_modes.real, e) + 1j * np.ldexp(
        report.uncontrollable_modes.imag, e
    )
    modes = ", ".join(f"{complex(lam):.4g}" for lam in report.uncontrollable_modes)
    if options.require_controllable:
        raise InvalidInputError(
            f"(A, B) is not controllable: the controllability matrix [B, AB, ..., A^(n-1)B] has "
            f"rank {report.rank} < n = {report.n}; uncontrollable modes (eigenvalues of A): "
            f"[{modes}]. Pass LQROptions(require_controllable=False) if these modes are stable"
        )
    if not report.stabilizable(discrete=discrete):
        raise InvalidInputError(
            f"(A, B) is not stabilizable: uncontrollable unstable modes [{modes}]; no LQR gain "
            "can stabilize the system"
        )


def _result(
    A: FloatArray,
    B: FloatArray,
    K: FloatArray,
    ric: RiccatiResult,
    discrete: bool,
    t0: float,
) -> LQRResult:
    eig = np.linalg.eigvals(A - B @ K)
    stable = bool(np.max(np.abs(eig)) < 1.0) if discrete else bool(np.max(eig.real) < 0.0)
    return LQRResult(
        success=ric.success and stable,
        status=LQRStatus.SOLVED if ric.success else LQRStatus.NOT_CONVERGED,
        K=K,
        P=ric.P,
        closed_loop_eigenvalues=eig,
        stable=stable,
        discrete=discrete,
        riccati=ric,
        solve_time=time.perf_counter() - t0,
    )


def lqr(
    A: Any, B: Any, Q: Any, R: Any, options: LQROptions | None = None, *, initial_gain: Any = None
) -> LQRResult:
    """Continuous-time LQR gain ``K = R^-1 B^T P`` (``u = -K x``).

    Args:
        A: (n x n); B: (n x m); Q: (n x n) symmetric >= 0 [cost per unit state^2];
            R: (m x m) symmetric > 0 (scalars are multiples of the identity).
        options: see :class:`LQROptions`.
        initial_gain: stabilizing start for the Newton-Kleinman method.

    Raises:
        InvalidInputError: bad inputs, or ``(A, B)`` uncontrollable (the message names the
            uncontrollable modes).
        SolverError: no stabilizing Riccati solution.
    """
    options = options or LQROptions()
    t0 = time.perf_counter()
    A, B = system(A, B)
    n, m = B.shape
    Q = symmetric_psd(Q, "Q", n, definite=False)
    R = symmetric_psd(R, "R", m, definite=True)
    _check_pair(A, B, options, discrete=False)
    ric = solve_continuous_riccati(A, B, Q, R, options.riccati, initial_gain=initial_gain)
    K = np.linalg.solve(R, B.T @ ric.P)
    return _result(A, B, K, ric, False, t0)


def dlqr(
    A: Any, B: Any, Q: Any, R: Any, options: LQROptions | None = None, *, N: Any = None
) -> LQRResult:
    """Discrete-time LQR gain ``K = (R + B^T P B)^-1 (B^T P A + N^T)`` (``u_k = -K x_k``).

    With a cross term the stage cost is ``x^T Q x + u^T R u + 2 x^T N u``; substituting
    ``u = v - R^-1 N^T x`` removes it: the DARE is solved for ``A - B R^-1 N^T`` and
    ``Q - N R^-1 N^T`` (which must be positive semidefinite, i.e. ``[[Q, N], [N^T, R]] >= 0``).

    Args:
        A, B, Q, R, options: as :func:`lqr`.
        N: cross weight (n x m); ``None`` is zero.

    Raises:
        InvalidInputError: as :func:`lqr`, or ``[[Q, N], [N^T, R]]`` not positive semidefinite.
        SolverError: no stabilizing Riccati solution.
    """
    options = options or LQROptions()
    t0 = time.perf_counter()
    A, B = system(A, B)
    n, m = B.shape
    Q = symmetric_psd(Q, "Q", n, definite=False)
    R = symmetric_psd(R, "R", m, definite=True)
    _check_pair(A, B, options, discrete=True)
    if N is None:
        ric = solve_discrete_riccati(A, B, Q, R, options.riccati)
        P = ric.P
        K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        return _result(A, B, K, ric, True, t0)
    N_arr = as_float_array(N, "N")
    N = as_matrix(N_arr[:, None] if N_arr.ndim == 1 else N_arr, (n, m), "N")
    RinvNt = np.linalg.solve(R, N.T)
    Qbar = Q - N @ RinvNt
    Qbar = 0.5 * (Qbar + Qbar.T)
    eig_min = float(np.min(np.linalg.eigvalsh(Qbar))) if n else 0.0
    if eig_min < -1e-10 * max(1.0, float(np.max(np.abs(Q)))):
        raise InvalidInputError(
            "the stage cost [[Q, N], [N^T, R]] must be positive semidefinite: Q - N R^-1 N^T "
            f"has the eigenvalue {eig_min:.3g}; reduce N or increase Q"
        )
    ric = solve_discrete_riccati(A - B @ RinvNt, B, Qbar, R, options.riccati)
    P = ric.P
    K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A + N.T)
    return _result(A, B, K, ric, True, t0)
