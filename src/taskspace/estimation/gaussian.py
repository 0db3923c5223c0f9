"""Gaussian identities of slide 6:10: density, product and propagation.

These closed forms are the references that the Kalman filter equations are derived from:

* product: ``N(x|a,A) N(x|b,B) = N(x | B(A+B)^-1 a + A(A+B)^-1 b, A(A+B)^-1 B) N(a|b, A+B)``
* propagation: ``int_y N(x | a + F y, A) N(y | b, B) dy = N(x | a + F b, A + F B F^T)``

Thread safety: a :class:`Gaussian` is an immutable value (frozen dataclass) whose methods build new
arrays, so it may be shared by threads as long as nobody modifies its ``mean``/``cov`` arrays.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_matrix, as_vector
from taskspace.errors import InvalidInputError
from taskspace.estimation.covariance import as_covariance


@dataclass(frozen=True)
class Gaussian:
    """A multivariate Gaussian ``N(x | mean, cov)``.

    Attributes:
        mean: ``(n,)`` mean.
        cov: ``(n, n)`` covariance (symmetric positive semidefinite, checked).

    Raises:
        InvalidInputError: a mean or covariance that is not finite real numbers of matching
            sizes, or a covariance that is not symmetric positive semidefinite.
    """

    mean: FloatArray
    cov: FloatArray

    def __post_init__(self) -> None:
        # was not checked: a negative, NaN, non-square or text covariance made a "Gaussian"
        mean = as_vector(self.mean, None, "mean")
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "cov", as_covariance(self.cov, mean.shape[0], "cov"))


def gaussian_logpdf(x: Any, mean: Any, cov: Any) -> float:
    """Log density ``log N(x | a, A) = -1/2 (x-a)^T A^-1 (x-a) - 1/2 log|2 pi A|`` (slide 6:9).

    Args:
        x: ``(n,)`` point.
        mean: ``(n,)`` mean ``a``.
        cov: ``(n, n)`` positive-definite covariance ``A``.

    Returns:
        The log density.
    """
    a = as_vector(mean, None, "mean")
    n = a.shape[0]
    xv = as_vector(x, n, "x")
    A = as_covariance(cov, n, "cov", positive_definite=True)
    try:
        L = np.linalg.cholesky(A)
    except np.linalg.LinAlgError as exc:  # pragma: no cover - guarded by as_covariance
        raise InvalidInputError(f"cov is not positive definite: {exc}") from exc
    r = np.linalg.solve(L, xv - a)
    logdet = 2.0 * float(np.sum(np.log(np.diag(L))))
    return float(-0.5 * r @ r - 0.5 * (n * np.log(2.0 * np.pi) + logdet))


def gaussian_product(a: Any, A: Any, b: Any, B: Any) -> tuple[Gaussian, float]:
    """Product of two Gaussian densities in the same variable (slide 6:10).

    ``N(x|a,A) N(x|b,B) = N(x | c, C) N(a | b, A + B)`` with
    ``C = A (A+B)^-1 B`` and ``c = B (A+B)^-1 a + A (A+B)^-1 b``.

    Args:
        a: ``(n,)`` first mean.
        A: ``(n, n)`` first covariance.
        b: ``(n,)`` second mean.
        B: ``(n, n)`` second covariance.

    Returns:
        The normalized product ``N(x | c, C)`` and ``log N(a | b, A + B)``.
    """
    av = as_vector(a, None, "a")
    n = av.shape[0]
    bv = as_vector(b, n, "b")
    Am = as_covariance(A, n, "A")
    Bm = as_covariance(B, n, "B")
    S = Am + Bm
    try:
        Sa = np.linalg.solve(S, np.column_stack([av, Bm]))
        Sb = np.linalg.solve(S, bv)
    except np.linalg.LinAlgError as exc:
        raise InvalidInputError(f"A + B is singular: {exc}") from exc
    mean = Bm @ Sa[:, 0] + Am @ Sb
    cov = Am @ Sa[:, 1:]
    cov = 0.5 * (cov + cov.T)
    return Gaussian(mean, cov), gaussian_logpdf(av, bv, S)


def gaussian_propagation(a: Any, A: Any, F: Any, b: Any, B: Any) -> Gaussian:
    """Marginal of a linear-Gaussian chain (slide 6:10).

    ``int_y N(x | a + F y, A) N(y | b, B) dy = N(x | a + F b, A + F B F^T)``.

    Args:
        a: ``(n,)`` offset.
        A: ``(n, n)`` conditional covariance.
        F: ``(n, m)`` linear map.
        b: ``(m,)`` mean of ``y``.
        B: ``(m, m)`` covariance of ``y``.

    Returns:
        The marginal Gaussian over ``x``.
    """
    av = as_vector(a, None, "a")
    n = av.shape[0]
    Fm = as_matrix(F, (n, None), "F")
    m = Fm.shape[1]
    bv = as_vector(b, m, "b")
    Am = as_covariance(A, n, "A")
    Bm = as_covariance(B, m, "B")
    with np.errstate(over="ignore", invalid="ignore"):
        cov = Am + Fm @ Bm @ Fm.T
        mean = av + Fm @ bv
    if not (np.isfinite(cov).all() and np.isfinite(mean).all()):  # was: overflow warnings
        raise InvalidInputError(
            "gaussian_propagation overflows (F B F^T or F b beyond the floats): rescale F, b, B"
        )
    return Gaussian(mean, 0.5 * (cov + cov.T))
