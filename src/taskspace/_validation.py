"""Shared input validation helpers used at the public boundary of every module."""

from __future__ import annotations

import functools
import importlib.util
import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from taskspace.errors import (
    InvalidInputError,
    MissingDependencyError,
    ModelLoadError,
    NotFiniteError,
    ShapeError,
)

FloatArray = npt.NDArray[np.float64]


# (a boolean array is a mask, not numbers: GraspContact(position=[True, False, True]) was
# taken as (1, 0, 1))
_REJECTED_KINDS = {
    "b": "boolean",
    "c": "complex",
    "U": "text",
    "S": "bytes",
    "M": "datetime",
    "m": "timedelta",
}


def as_float_array(x: Any, name: str) -> FloatArray:
    """Convert ``x`` to a float64 array of any shape, refusing what is not real numbers.

    NumPy would turn ``None`` into NaN, drop the imaginary part of complex values (with only
    a warning) and parse strings; each of these is an error here.

    Args:
        x: array-like input.
        name: argument name used in error messages.

    Returns:
        A float64 array (``x`` itself when it already is one).

    Raises:
        InvalidInputError: if ``x`` is ``None``, boolean, complex, text, or not numeric.
    """
    if isinstance(x, np.ndarray):
        if x.dtype == np.float64:
            return x
        kind = _REJECTED_KINDS.get(x.dtype.kind)
    elif x is None:
        raise InvalidInputError(f"{name} must be an array of real numbers, got None")
    elif isinstance(x, (complex, np.complexfloating)):
        kind = "complex"
    elif isinstance(x, (bool, np.bool_)):
        kind = "boolean"
    elif isinstance(x, (str, bytes)):
        kind = "text"
    else:
        kind = None
    if kind is not None:
        raise InvalidInputError(
            f"{name} must be real numbers, got {kind} values"
            + (
                " (pass x.real if the imaginary part is meant to be zero)"
                if kind == "complex"
                else ""
            )
        )
    try:
        if not isinstance(x, (list, tuple)) and not (
            isinstance(x, np.ndarray) and x.dtype.kind == "O"
        ):
            return np.asarray(x, dtype=np.float64)
        # nested sequences may hold complex, text or None entries (NumPy would truncate
        # complex values, parse text and turn None into NaN)
        raw = np.asarray(x)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(
            f"{name} must be an array of real numbers (one shape, no None): {exc}"
        ) from exc
    if raw.dtype.kind in _REJECTED_KINDS:
        return as_float_array(raw, name)
    if raw.dtype.kind == "O":
        # entries of an object array (e.g. [10**30, 1j]: a big int makes NumPy keep objects)
        for item in raw.flat:
            if item is None:
                raise InvalidInputError(
                    f"{name} must be an array of real numbers, got a None entry"
                )
            if isinstance(item, (bool, np.bool_)):
                raise InvalidInputError(
                    f"{name} must be real numbers, got a boolean entry {item!r}"
                )
            if isinstance(item, (complex, np.complexfloating, str, bytes)):
                what = "text" if isinstance(item, (str, bytes)) else "complex"
                raise InvalidInputError(
                    f"{name} must be real numbers, got a {what} entry {item!r}"
                    + (
                        " (pass x.real if the imaginary part is meant to be zero)"
                        if what == "complex"
                        else ""
                    )
                )
    try:
        return raw.astype(np.float64, copy=False)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(
            f"{name} must be an array of real numbers (one shape, no None): {exc}"
        ) from exc


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
        InvalidInputError: if ``x`` is not real numbers (``None``, strings, complex...).
    """
    arr = as_float_array(x, name)
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        raise ShapeError(name, (size if size is not None else -1,), tuple(arr.shape))
    check_finite(arr, name)
    return arr if arr.flags.c_contiguous else np.ascontiguousarray(arr)


def as_matrix(x: Any, shape: tuple[int | None, int | None], name: str) -> FloatArray:
    """Convert ``x`` to a finite float64 matrix of the given shape (``None`` = any).

    Raises:
        ShapeError: if ``x`` is not 2-D of the given shape.
        NotFiniteError: if ``x`` has NaN or inf entries.
        InvalidInputError: if ``x`` is not real numbers (``None``, strings, complex...).
    """
    arr = as_float_array(x, name)
    if arr.ndim != 2 or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        expected = tuple(-1 if s is None else s for s in shape)
        raise ShapeError(name, expected, tuple(arr.shape))
    check_finite(arr, name)
    return arr


def check_finite(
    arr: npt.NDArray[Any], name: str, *, allow_inf: bool = False, by_row: bool = False
) -> None:
    """Raise :class:`NotFiniteError` if ``arr`` has NaN or inf entries.

    ``allow_inf``: only NaN is refused (bounds, where an infinite entry means "no bound").
    ``by_row``: the error's indices are the rows (first axis) holding a bad entry, not the
    flat indices of the entries.
    """
    # Fast path: the sum of squares is finite when every entry is (a huge finite entry may
    # overflow it; the exact test below then decides). ``np.vdot``, not ``@``/``np.dot``:
    # those check the FPU flags afterwards and warned "overflow encountered in matmul" for
    # any finite entry above ~1e154; ``vdot`` is as fast and sets no warning.
    flat = arr.ravel()
    total = float(np.vdot(flat, flat))
    if math.isfinite(total) or (allow_inf and not math.isnan(total)):
        return
    bad = np.isnan(arr) if allow_inf else ~np.isfinite(arr)
    if bad.any():
        if by_row and arr.ndim > 1:
            where = np.flatnonzero(bad.reshape(arr.shape[0], -1).any(axis=1))
        else:
            where = np.flatnonzero(bad.ravel())
        raise NotFiniteError(name, [int(i) for i in where[:20]])


def as_scalar(value: Any, name: str) -> float:
    """Return ``value`` as a finite float, or raise :class:`InvalidInputError`.

    Accepts Python and NumPy real numbers and one-element real arrays; refuses ``None``,
    booleans, strings, complex numbers, NaN and inf.
    """
    v = _to_float(value, name)
    if not math.isfinite(v):
        raise InvalidInputError(f"{name} must be a finite number, got {value!r}")
    return v


def check_int(value: Any, name: str, *, minimum: int | None = None) -> int:
    """Return ``value`` as an ``int`` if it is an integer ``>= minimum``, else raise.

    Floats are accepted only when integral (``3.0``); booleans, NaN and inf are refused.
    """
    if isinstance(value, (bool, np.bool_)) or value is None:
        raise InvalidInputError(f"{name} must be an integer, got {value!r}")
    if isinstance(value, (int, np.integer)):
        out = int(value)
    else:
        v = _to_float(value, name)
        if not (math.isfinite(v) and v == int(v)):
            raise InvalidInputError(f"{name} must be an integer, got {value!r}")
        out = int(v)
    if minimum is not None and out < minimum:
        raise InvalidInputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return out


def _to_float(value: Any, name: str) -> float:
    if isinstance(value, np.ndarray):
        if value.size != 1 or value.dtype.kind not in "iuf":
            raise InvalidInputError(
                f"{name} must be a real number, got an array of shape {value.shape} and dtype "
                f"{value.dtype}"
            )
        value = value.reshape(()).item()
    if isinstance(value, (complex, np.complexfloating)):
        raise InvalidInputError(f"{name} must be a real number, got the complex {value!r}")
    if isinstance(value, (str, bytes, bool, np.bool_)) or value is None:
        # (a bool is a flag, not a number: gamma=True was taken as 1.0)
        raise InvalidInputError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(f"{name} must be a number, got {value!r}") from exc


def check_positive(value: Any, name: str, *, strict: bool = True) -> float:
    """Return ``value`` as float if it is (strictly) positive and finite, else raise."""
    if value.__class__ is float:  # fast path (the hot loops pass floats)
        v = value
    else:
        v = _to_float(value, name)
    if not math.isfinite(v) or (v <= 0.0 if strict else v < 0.0):
        relation = "> 0" if strict else ">= 0"
        raise InvalidInputError(f"{name} must be finite and {relation}, got {value!r}")
    return v


# Iteration caps and time limits of iterative algorithms (one convention, issue #15): a cap is
# a non-negative integer (a bool or a float such as 2.5 is refused; caps beyond int64 are
# clamped, never reached anyway); a time limit is a number of seconds >= 0, ``None`` or
# ``math.inf`` meaning no limit, NaN refused; no limit at all (no time limit and no cap) is
# refused where a cap may be ``None``.
MAX_INT64 = (1 << 63) - 1


def check_count(value: Any, name: str, *, minimum: int = 0) -> int:
    """Return ``value`` as an int if it is an integer ``>= minimum``, else raise.

    Integers beyond ``2**63 - 1`` are clamped to it (a compiled kernel counts with int64).
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InvalidInputError(
            f"{name} must be an integer >= {minimum}, got {value!r} ({type(value).__name__})"
        )
    v = int(value)
    if v < minimum:
        raise InvalidInputError(f"{name} must be an integer >= {minimum}, got {v}")
    return min(v, MAX_INT64)


def check_time_limit(value: Any, name: str = "time_limit_s") -> float:
    """Return a time limit [s] as a float, ``math.inf`` for ``None`` (no limit); NaN refused."""
    if value is None:
        return math.inf
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        raise InvalidInputError(
            f"{name} must be a number of seconds >= 0 or None (no limit), got {value!r}"
        )
    v = float(value)
    if math.isnan(v) or v < 0.0:
        raise InvalidInputError(
            f"{name} must be a number of seconds >= 0, math.inf or None (no limit), got {v}"
        )
    return v


def check_limits(
    max_iterations: Any,
    time_limit_s: Any,
    *,
    names: tuple[str, str] = ("max_iterations", "time_limit_s"),
    minimum: int = 0,
) -> tuple[int | None, float]:
    """Validate an iteration cap (``None`` = none) and a time limit together.

    Returns:
        ``(cap or None, time limit [s], math.inf for none)``.

    Raises:
        InvalidInputError: a bad value, or neither a finite time limit nor a cap (the loop
            could never end).
    """
    limit = check_time_limit(time_limit_s, names[1])
    cap = None if max_iterations is None else check_count(max_iterations, names[0], minimum=minimum)
    if cap is None and math.isinf(limit):
        raise InvalidInputError(
            f"{names[0]}=None needs a finite {names[1]} (otherwise the loop may never end); "
            f"give {names[0]} an integer or {names[1]} a number of seconds"
        )
    return cap, limit


def check_seed(value: Any, name: str = "seed") -> int:
    """Return a random seed as an int ``>= 0`` (what ``np.random.default_rng`` accepts)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InvalidInputError(f"{name} must be an integer >= 0, got {value!r}")
    if int(value) < 0:
        raise InvalidInputError(f"{name} must be an integer >= 0, got {int(value)}")
    return int(value)


# ---------------------------------------------------------------------------- YAML files
class YamlLines:
    """Where the parts of a YAML document are: ``where(*keys)`` gives ``"file:line"``.

    Keys walk the document as the parsed data would be indexed: mapping keys (compared as
    text) and sequence indices. A key that is not found gives the line of the deepest node
    found (or the file alone).
    """

    def __init__(self, path: Path, root: yaml.Node | None) -> None:
        self.path = path
        self._root = root

    def line(self, *keys: Any) -> int | None:
        """1-based line of the node at ``keys`` (or of its deepest existing ancestor)."""
        node = self._root
        if node is None:
            return None
        for key in keys:
            child: yaml.Node | None = None
            if isinstance(node, yaml.MappingNode):
                for key_node, value_node in node.value:
                    if isinstance(key_node, yaml.ScalarNode) and key_node.value == str(key):
                        child = value_node
                        break
            elif isinstance(node, yaml.SequenceNode) and isinstance(key, int):
                if 0 <= key < len(node.value):
                    child = node.value[key]
            if child is None:
                break
            node = child
        return int(node.start_mark.line) + 1

    def where(self, *keys: Any) -> str:
        """``"file:line"`` of the node at ``keys``."""
        line = self.line(*keys)
        return f"{self.path}:{line}" if line is not None else str(self.path)


_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_yaml(path: str | Path, what: str = "YAML file") -> tuple[Any, YamlLines]:
    """Parse a YAML file (safe loader) and keep the line of every node.

    Args:
        path: the file.
        what: what the file is, for error messages (``"robot registry"``...).

    Returns:
        ``(data, lines)``: the parsed document and its :class:`YamlLines`.

    Raises:
        ModelLoadError: missing or unreadable file, or malformed YAML (the message gives
            ``file:line:column`` of the problem).
    """
    p = Path(path)
    if not p.is_file():
        raise ModelLoadError(f"{what} not found: {p}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelLoadError(f"cannot read {what} {p}: {exc}") from exc
    # One parse: the nodes (their lines) and the data built from them, as yaml.safe_load
    # builds it. libyaml's parser when PyYAML has it (the same nodes, ~3x faster).
    loader = _SAFE_LOADER(text)
    try:
        root = loader.get_single_node()
        data = loader.construct_document(root) if root is not None else None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        place = f"{p}:{mark.line + 1}:{mark.column + 1}" if mark is not None else str(p)
        problem = " ".join(str(x) for x in (exc.context, exc.problem) if x)
        raise ModelLoadError(f"{place}: malformed YAML in {what}: {problem}") from exc
    except yaml.YAMLError as exc:
        raise ModelLoadError(f"{p}: malformed YAML in {what}: {exc}") from exc
    finally:
        loader.dispose()
    return data, YamlLines(p, root)


# ---------------------------------------------------------------------- optional dependencies
# The algorithms need only the core dependencies. The viewer and plotting stack (meshcat,
# matplotlib, Pillow, playwright) is the ``viz`` extra and Ray the ``ray`` extra; ``all`` has
# both (what ``make`` installs and the README's quick start asks for). Code that needs an extra
# calls :func:`require_extra` first, so a missing package gives one clear error naming the
# install command instead of a bare ``ModuleNotFoundError`` deep inside.

EXTRAS: dict[str, tuple[str, ...]] = {
    "viz": ("meshcat", "matplotlib", "PIL", "umsgpack"),
    "ray": ("ray",),
}
"""Import names of the packages of each extra (``PIL`` is Pillow, ``umsgpack`` is
u-msgpack-python; playwright, also in ``viz``, is checked by the snapshots themselves)."""


@functools.cache
def missing_modules(extra: str) -> tuple[str, ...]:
    """The import names of ``extra``'s packages that are not installed."""
    if extra not in EXTRAS:
        raise KeyError(f"unknown extra {extra!r}; extras are {sorted(EXTRAS)}")
    return tuple(m for m in EXTRAS[extra] if importlib.util.find_spec(m) is None)


def require_extra(extra: str, purpose: str) -> None:
    """Raise :class:`MissingDependencyError` unless every package of ``extra`` is installed.

    Args:
        extra: name of the extra (``"viz"``, ``"ray"``).
        purpose: what needs it, for the message (``"taskspace.viz"``).
    """
    missing = missing_modules(extra)
    if missing:
        raise MissingDependencyError(purpose, extra, missing)
