"""Lenient but exact input conversion for the filters (the shapes filterpy users pass)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, check_finite
from taskspace.errors import (
    CallbackError,
    InvalidInputError,
    ShapeError,
    SolverError,
    TaskspaceError,
)
from taskspace.estimation.covariance import as_covariance


def as_measurement(z: Any, m: int, name: str) -> FloatArray:
    """A vector of length ``m`` from ``(m,)``, a column ``(m, 1)`` or, when ``m == 1``, a scalar.

    Raises:
        ShapeError: any other shape (a row ``(1, m)`` is refused: it is ambiguous).
        NotFiniteError: NaN or inf entries.
        InvalidInputError: not real numbers (``None``, complex, text...).
    """
    arr = as_float_array(z, name)
    if arr.shape == (m,):
        pass
    elif arr.shape == (m, 1) or (m == 1 and arr.size == 1):
        arr = arr.reshape(m)
    else:
        raise ShapeError(name, (m,), tuple(arr.shape))
    check_finite(arr, name)
    return arr if arr.flags.c_contiguous else np.ascontiguousarray(arr)


def as_state(x: Any, n: int | None, name: str) -> FloatArray:
    """A state vector from ``(n,)`` or a column ``(n, 1)`` (a copy the filter may own)."""
    arr = as_float_array(x, name)
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1 or (n is not None and arr.shape[0] != n):
        raise ShapeError(name, (n if n is not None else -1,), tuple(arr.shape))
    check_finite(arr, name)
    return np.array(arr, dtype=np.float64)


def as_noise_covariance(R: Any, m: int | None, name: str) -> FloatArray:
    """A positive-definite ``(m, m)`` noise covariance; a scalar ``r > 0`` means ``r I``."""
    arr = as_float_array(R, name)
    if arr.ndim == 0:
        r = float(arr)
        m = 1 if m is None else m
        if not (np.isfinite(r) and r > 0.0):
            raise InvalidInputError(
                f"{name} as a scalar r (for r I) must be finite and > 0 (positive definite), "
                f"got {R!r}"
            )
        return r * np.eye(m)
    return as_covariance(arr, m, name, positive_definite=True)


def call_model(fn: Callable[..., Any], name: str, *args: Any) -> Any:
    """``fn(*args)``; an exception other than a TaskspaceError becomes a CallbackError.

    The rule of every filter that calls user functions (see :class:`CallbackError`).
    """
    try:
        return fn(*args)
    except TaskspaceError:
        raise
    except Exception as exc:
        raise CallbackError(name, exc) from exc


def model_output(value: Any, shape: tuple[int, ...], name: str) -> FloatArray:
    """Validate what a user model (``f``, ``h``, a Jacobian) returned: shape and finiteness.

    A column ``(k, 1)`` is accepted for a vector of length ``k``.
    """
    arr = as_float_array(value, f"{name} output")
    if arr.shape != shape and len(shape) == 1 and arr.size == shape[0]:
        if arr.shape == (shape[0], 1) or arr.ndim == 0:  # a column, or a scalar for m = 1
            arr = arr.reshape(shape)
    if arr.shape != shape:
        raise ShapeError(f"{name} output", shape, tuple(arr.shape))
    if not np.isfinite(arr).all():
        raise InvalidInputError(
            f"{name} returned non-finite values (NaN or inf) {arr.tolist()}: the filter cannot "
            "continue; check the model at the current estimate"
        )
    return arr


def checked_belief(x: FloatArray, P: FloatArray, step: str) -> tuple[FloatArray, FloatArray]:
    """Return ``(x, P)`` if both are finite, else raise (the caller keeps its old belief).

    Raises:
        SolverError: a non-finite mean or covariance (overflow of values far outside the
            scale of the filter, e.g. a measurement of 1e200 with unit noise).
    """
    if not (np.isfinite(x).all() and np.isfinite(P).all()):
        raise SolverError(
            f"the {step} gave a non-finite mean or covariance (overflow): the belief is left "
            "unchanged; rescale the states and measurements (units) or check the inputs"
        )
    return x, P
