"""Controller (and observer) design by eigenvalue assignment: pole placement.

For ``x' = A x + B u`` with ``u = -K x`` the closed loop is ``x' = (A - B K) x``. If ``(A, B)``
is controllable, any self-conjugate set of ``n`` eigenvalues can be assigned.

* Ackermann (single input): ``K = e_n^T C^-1 phi(A)`` with ``C = [B, A B, ..., A^{n-1} B]``
  the controllability matrix and ``phi(s) = prod_i (s - p_i)`` the desired characteristic
  polynomial. Exact in exact arithmetic, numerically poor for large ``n``.
* Robust (multi-input): among the many gains of a multi-input system, choose the one whose
  closed-loop eigenvector matrix ``X`` is best conditioned (Kautsky-Nichols-Van Dooren, Tits-
  Yang), as done by ``scipy.signal.place_poles``; a well-conditioned ``X`` keeps the poles
  where they were put when ``A`` or ``K`` are perturbed (Bauer-Fike).

An observer ``x_hat' = A x_hat + B u + L (y - C x_hat)`` has error dynamics ``A - L C``; its
gain is the dual design ``L = place(A^T, C^T, poles)^T``.

Thread safety: the functions keep their state local to the call; :class:`PolePlacementMethod` and
:class:`PolePlacementOptions` are immutable; a :class:`PolePlacementResult` is plain result data
(arrays), not locked: do not modify it while another thread reads it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, check_count, check_positive
from taskspace.control._linear import system
from taskspace.control.controllability import controllability, controllability_matrix
from taskspace.errors import InvalidInputError, SolverError


class PolePlacementMethod(enum.Enum):
    """Algorithm of :func:`place_poles`."""

    ACKERMANN = "ackermann"
    """Ackermann's formula (single input only)."""
    TITS_YANG = "tits_yang"
    """Robust assignment of Tits and Yang (``scipy.signal.place_poles``)."""
    KNV0 = "knv0"
    """Robust assignment of Kautsky, Nichols and Van Dooren, method 0."""


@dataclass(frozen=True, kw_only=True)
class PolePlacementOptions:
    """Settings of :func:`place_poles`.

    Attributes:
        method: ``"tits_yang"`` (default), ``"knv0"`` or ``"ackermann"`` (single input).
        rtol: convergence tolerance of the robust methods (relative change of ``det X``).
        max_iterations: iteration limit of the robust methods.
        tolerance: the achieved poles must match the requested ones within
            ``tolerance * max(1, |p|)``; otherwise :class:`SolverError`.
    """

    method: PolePlacementMethod | str = PolePlacementMethod.TITS_YANG
    rtol: float = 1e-3
    max_iterations: int = 30
    tolerance: float = 1e-6


@dataclass
class PolePlacementResult:
    """A pole-placement design ``u = -K x``.

    Attributes:
        K: feedback gain (m x n).
        requested_poles: the poles asked for (complex, sorted).
        computed_poles: eigenvalues of ``A - B K`` (complex, sorted like ``requested_poles``).
        max_error: ``max_i |computed_i - requested_i|``.
        method: the method used.
        eigenvector_condition: condition number of the closed-loop eigenvector matrix (the
            robustness that the robust methods maximize; lower is better).
    """

    K: FloatArray
    requested_poles: np.ndarray
    computed_poles: np.ndarray
    max_error: float
    method: PolePlacementMethod
    eigenvector_condition: float


def _poles(poles: Any, n: int) -> np.ndarray:
    raw = np.asarray(poles, dtype=object) if not isinstance(poles, np.ndarray) else poles
    if (
        poles is None
        or raw.dtype.kind in "SUV"
        or (
            raw.dtype.kind == "O"
            and any(item is None or isinstance(item, (str, bytes)) for item in raw.flat)
        )
    ):
        raise InvalidInputError(f"poles must be real or complex numbers, got {poles!r}")
    try:
        p = np.atleast_1d(np.asarray(poles, dtype=complex)).ravel()
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"poles must be real or complex numbers: {exc}") from exc
    if p.size != n:
        raise InvalidInputError(f"need exactly n = {n} poles, got {p.size}")
    if not np.all(np.isfinite(p)):
        raise InvalidInputError("poles must be finite")
    scale = max(1.0, float(np.max(np.abs(p))))
    conj = np.sort_complex(np.conj(p))
    if np.max(np.abs(np.sort_complex(p) - conj)) > 1e-9 * scale:
        raise InvalidInputError(
            "complex poles must come in conjugate pairs (a real gain gives a real "
            "characteristic polynomial)"
        )
    return p


def _match(requested: np.ndarray, computed: np.ndarray) -> np.ndarray:
    """``computed`` reordered to pair each requested pole with its nearest computed one."""
    from scipy.optimize import linear_sum_assignment

    cost = np.abs(requested[:, None] - computed[None, :])
    _, cols = linear_sum_assignment(cost)
    return computed[cols]


def acker(A: Any, B: Any, poles: Any) -> FloatArray:
    """Ackermann's formula ``K = e_n^T C^-1 phi(A)`` for a single input (1 x n gain).

    Args:
        A: (n x n); B: (n,) or (n x 1); poles: n desired closed-loop eigenvalues
            (complex ones in conjugate pairs).

    Raises:
        InvalidInputError: more than one input, wrong number of poles, or ``(A, B)`` not
            controllable.
    """
    A, B = system(A, B)
    n, m = B.shape
    if m != 1:
        raise InvalidInputError(
            f"Ackermann's formula needs a single input, B has {m} columns; use "
            "place_poles(..., PolePlacementOptions(method='tits_yang')) for several inputs"
        )
    p = _poles(poles, n)
    report = controllability(A, B)
    if not report.controllable:
        raise InvalidInputError(
            f"(A, B) is not controllable (rank {report.rank} < n = {n}): the poles cannot all "
            "be placed"
        )
    coeffs = np.real(np.poly(p))  # phi(s) = s^n + c1 s^{n-1} + ... + cn
    phi = np.zeros((n, n))
    with np.errstate(over="ignore", invalid="ignore"):
        for c in coeffs:  # Horner: phi(A) = (((A + c1) A + c2) A + ...)
            phi = phi @ A + c * np.eye(n)
        e_n = np.zeros(n)
        e_n[-1] = 1.0
        row = np.linalg.solve(controllability_matrix(A, B).T, e_n)
        K = np.asarray(row @ phi, dtype=float)[None, :]
    if not np.all(np.isfinite(K)):  # was returned as a NaN gain
        raise InvalidInputError(
            "Ackermann's formula overflowed float64 (phi(A) or C^-1 not representable): "
            "rescale the state or the time unit, or use place_poles(..., method='tits_yang')"
        )
    return K


def place_poles(
    A: Any, B: Any, poles: Any, options: PolePlacementOptions | None = None
) -> PolePlacementResult:
    """Gain ``K`` such that ``eig(A - B K)`` are the requested poles.

    Args:
        A: (n x n); B: (n x m); poles: n desired closed-loop eigenvalues (complex ones in
            conjugate pairs; a pole may be repeated at most ``rank B`` times for the robust
            methods).
        options: see :class:`PolePlacementOptions`.

    Raises:
        InvalidInputError: bad method name, wrong number of poles, not controllable, or a
            pole repeated more often than ``rank B``.
        SolverError: the achieved poles miss the requested ones by more than the tolerance.
    """
    options = options or PolePlacementOptions()
    tolerance = check_positive(options.tolerance, "PolePlacementOptions.tolerance", strict=False)
    rtol = check_positive(options.rtol, "PolePlacementOptions.rtol", strict=False)
    max_iterations = check_count(
        options.max_iterations, "PolePlacementOptions.max_iterations", minimum=1
    )
    try:
        method = PolePlacementMethod(options.method)
    except ValueError:
        valid = ", ".join(repr(m.value) for m in PolePlacementMethod)
        raise InvalidInputError(
            f"unknown pole placement method {options.method!r}; valid methods are: {valid}"
        ) from None
    A, B = system(A, B)
    n, m = B.shape
    p = _poles(poles, n)
    if method is PolePlacementMethod.ACKERMANN:
        K = acker(A, B, p)
    else:
        report = controllability(A, B)
        if not report.controllable:
            raise InvalidInputError(
                f"(A, B) is not controllable (rank {report.rank} < n = {n}); uncontrollable "
                f"modes {report.uncontrollable_modes} cannot be moved"
            )
        import scipy.signal

        rank_b = int(np.linalg.matrix_rank(B))
        values, counts = np.unique(np.round(p, 12), return_counts=True)
        if np.max(counts) > rank_b:
            raise InvalidInputError(
                f"pole {values[np.argmax(counts)]} is repeated {int(np.max(counts))} times but "
                f"rank B = {rank_b}: the robust methods place a pole at most rank B times; "
                "perturb the repeated poles slightly"
            )
        name = "YT" if method is PolePlacementMethod.TITS_YANG else "KNV0"
        try:
            out = scipy.signal.place_poles(A, B, p, method=name, rtol=rtol, maxiter=max_iterations)
        except ValueError as exc:
            raise InvalidInputError(f"pole placement failed: {exc}") from exc
        K = np.asarray(out.gain_matrix, dtype=float).reshape(m, n)
    eig, vec = np.linalg.eig(A - B @ K)
    requested = np.sort_complex(p)
    computed = _match(requested, eig)
    err = float(np.max(np.abs(computed - requested))) if n else 0.0
    scale = max(1.0, float(np.max(np.abs(p)))) if n else 1.0
    if not err <= tolerance * scale:  # a NaN error is a miss
        raise SolverError(
            f"pole placement ({method.value}) missed the requested poles by {err:.3g} "
            f"(tolerance {tolerance * scale:.3g}); the problem is ill-conditioned "
            "(try the robust method or less extreme poles)"
        )
    return PolePlacementResult(
        K=K,
        requested_poles=requested,
        computed_poles=computed,
        max_error=err,
        method=method,
        eigenvector_condition=float(np.linalg.cond(vec)),
    )


def place(A: Any, B: Any, poles: Any, options: PolePlacementOptions | None = None) -> FloatArray:
    """The gain of :func:`place_poles` (``u = -K x``), like ``control.place``."""
    return place_poles(A, B, poles, options).K


def observer_gain(
    A: Any, C: Any, poles: Any, options: PolePlacementOptions | None = None
) -> FloatArray:
    """Observer gain ``L`` with ``eig(A - L C)`` = ``poles``: ``L = place(A^T, C^T)^T`` (n x p).

    Args:
        A: (n x n); C: (p x n) (a vector is one output); poles: n desired error-dynamics
            eigenvalues; options: see :class:`PolePlacementOptions`.

    Raises:
        InvalidInputError: ``(A, C)`` not observable, or as :func:`place_poles`.
    """
    A_arr = as_float_array(A, "A")
    C_arr = as_float_array(C, "C")
    if C_arr.ndim == 1:
        C_arr = C_arr[None, :]
    try:
        K = place_poles(A_arr.T, C_arr.T, poles, options).K
    except InvalidInputError as exc:
        if "not controllable" in str(exc):
            raise InvalidInputError(
                f"(A, C) is not observable: the observer poles cannot all be placed ({exc})"
            ) from exc
        raise
    if K.ndim == 1:
        K = K[None, :]
    return np.asarray(K.T, dtype=float)
