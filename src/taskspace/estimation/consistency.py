"""Filter consistency metrics: NEES and NIS with chi-square acceptance bounds.

* NEES (normalized estimation error squared): ``e_k = (x_k - x_hat_k)^T P_k^-1 (x_k - x_hat_k)``,
  ``chi^2(n)``-distributed for a consistent filter;
* NIS (normalized innovation squared): ``r_k^T S_k^-1 r_k ~ chi^2(m)``.

Averaged over ``M`` Monte Carlo runs, ``M * mean(e)`` is ``chi^2(M n)``; :func:`chi2_bounds`
gives the two-sided acceptance interval of the average.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.stats

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_int
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, SolverError
from taskspace.estimation.covariance import _PSD_RTOL, _SYM_RTOL


def nees(truth: Any, means: Any, covs: Any) -> FloatArray:
    """NEES of each step: ``(x - x_hat)^T P^-1 (x - x_hat)``.

    Args:
        truth: ``(T, n)`` true states.
        means: ``(T, n)`` estimates.
        covs: ``(T, n, n)`` estimate covariances.

    Returns:
        ``(T,)`` NEES values.

    Raises:
        ShapeError: ``truth`` not ``(T, n)``, or ``means``/``covs`` of other shapes.
        InvalidInputError: a covariance is not symmetric or not positive definite.
        SolverError: a covariance is singular.
    """
    x = as_float_array(truth, "truth")
    m = as_float_array(means, "means")
    P = as_float_array(covs, "covs")
    if x.ndim != 2:  # was "means must have shape (2,), got (2,)" for 1-D truth and means
        raise ShapeError("truth", (-1, -1), tuple(x.shape))
    if m.shape != x.shape:
        raise ShapeError("means", tuple(x.shape), tuple(m.shape))
    if P.shape != (*x.shape, x.shape[1]):
        raise ShapeError("covs", (*x.shape, x.shape[1]), tuple(P.shape))
    for arr, name in ((x, "truth"), (m, "means"), (P, "covs")):
        if not np.isfinite(arr).all():
            raise NotFiniteError(name, [int(i) for i in np.flatnonzero(~np.isfinite(arr))[:20]])
    _check_covariances(P)
    e = x - m
    try:
        sol = np.linalg.solve(P, e[..., None])[..., 0]
    except np.linalg.LinAlgError as exc:
        raise SolverError(f"a covariance is singular: {exc}") from exc
    return np.einsum("ti,ti->t", e, sol)


def _check_covariances(P: FloatArray) -> None:
    """Refuse a ``(T, n, n)`` stack with a non-symmetric or indefinite matrix.

    (An indefinite ``P`` gave a negative NEES, a non-symmetric one a meaningless value.) A
    singular ``P`` is left to the solve, which names it.
    """
    if P.size == 0:
        return
    scale = np.maximum(1.0, np.abs(P).max(axis=(1, 2)))
    asym = np.abs(P - P.transpose(0, 2, 1)).max(axis=(1, 2))
    bad = np.flatnonzero(asym > _SYM_RTOL * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInputError(
            f"covs[{k}] must be a symmetric covariance matrix; max |P - P^T| = {asym[k]:.3g}"
        )
    lam_min = np.linalg.eigvalsh(0.5 * (P + P.transpose(0, 2, 1)))[:, 0]
    bad = np.flatnonzero(lam_min < -_PSD_RTOL * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInputError(
            f"covs[{k}] must be a positive definite covariance matrix; smallest eigenvalue is "
            f"{lam_min[k]:.3g}"
        )


def chi2_bounds(dof: int, num_runs: int = 1, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided acceptance interval of the average of ``num_runs`` ``chi^2(dof)`` variables.

    ``[chi2.ppf((1-c)/2, M dof) / M, chi2.ppf((1+c)/2, M dof) / M]``.
    """
    dof = check_int(dof, "dof")
    num_runs = check_int(num_runs, "num_runs")
    confidence = as_scalar(confidence, "confidence")
    if dof < 1 or num_runs < 1 or not 0.0 < confidence < 1.0:
        raise InvalidInputError(
            f"need dof >= 1, num_runs >= 1, 0 < confidence < 1; got {dof}, {num_runs}, {confidence}"
        )
    k = float(dof * num_runs)  # a Python int past int64 (2**32 * 2**32) gave a bare TypeError
    lo = float(scipy.stats.chi2.ppf(0.5 * (1.0 - confidence), k)) / num_runs
    hi = float(scipy.stats.chi2.ppf(0.5 * (1.0 + confidence), k)) / num_runs
    return lo, hi
