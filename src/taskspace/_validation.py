"""Shared input validation helpers used at the public boundary of every module."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError

FloatArray = npt.NDArray[np.float64]


def as_vector(x: Any, size: int | None, name: str) -> FloatArray:
    """Convert ``x`` to a finite float64 vector of the given size.

    Args:
        x: array-like input.
        size: required length, or ``None`` to accept any length.
        name: argument name used in error messages.

    Returns:
        A contiguous float64 1-D array (a copy when conversion was needed).

    Raises:
        ShapeError: if ``x`` is not 1-D of length ``size``.
        NotFiniteError: if ``x`` has NaN or inf entries.
        InvalidInputError: if ``x`` cannot be converted to floats.
    """
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be an array of numbers: {exc}") from exc
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        raise ShapeError(name, (size if size is not None else -1,), tuple(arr.shape))
    check_finite(arr, name)
    return arr if arr.flags.c_contiguous else np.ascontiguousarray(arr)


def as_matrix(x: Any, shape: tuple[int | None, int | None], name: str) -> FloatArray:
    """Convert ``x`` to a finite float64 matrix of the given shape (``None`` = any)."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be an array of numbers: {exc}") from exc
    if arr.ndim != 2 or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        expected = tuple(-1 if s is None else s for s in shape)
        raise ShapeError(name, expected, tuple(arr.shape))
    check_finite(arr, name)
    return arr


def check_finite(arr: npt.NDArray[Any], name: str) -> None:
    """Raise :class:`NotFiniteError` if ``arr`` has NaN or inf entries."""
    # Fast path: the sum of squares is finite when every entry is (a huge finite entry may
    # overflow it; the exact test below then decides).
    flat = arr.ravel()
    if math.isfinite(float(flat @ flat)):
        return
    if not np.isfinite(arr).all():
        bad = np.flatnonzero(~np.isfinite(arr.ravel()))
        raise NotFiniteError(name, [int(i) for i in bad[:20]])


def check_positive(value: float, name: str, *, strict: bool = True) -> float:
    """Return ``value`` as float if it is (strictly) positive and finite, else raise."""
    v = float(value)
    if not math.isfinite(v) or (v <= 0.0 if strict else v < 0.0):
        relation = "> 0" if strict else ">= 0"
        raise InvalidInputError(f"{name} must be finite and {relation}, got {value!r}")
    return v
