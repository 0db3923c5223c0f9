"""Exceptions and warnings of taskspace.

Every error raised by taskspace derives from :class:`TaskspaceError`. Subclasses also derive
from the matching built-in (``ValueError``, ``KeyError``...) so generic handlers keep working.
Each carries the data needed to debug it as attributes.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any


class TaskspaceError(Exception):
    """Base class of every exception raised by taskspace."""


class TaskspaceWarning(UserWarning):
    """Base class of every warning emitted by taskspace."""


class ModelWarning(TaskspaceWarning):
    """A robot description was corrected on load (collision pairs pruned, limits missing)."""


class MissingDependencyError(TaskspaceError, ImportError):
    """An optional dependency (an extra of ``pip install "taskspace[...]"``) is not installed.

    Attributes:
        purpose: what needs it.
        extra: the extra that provides it.
        modules: the import names that are missing.
    """

    def __init__(self, purpose: str, extra: str, modules: Sequence[str]) -> None:
        self.purpose = purpose
        self.extra = extra
        self.modules = tuple(modules)
        super().__init__(
            f"{purpose} needs {', '.join(self.modules)} (not installed): "
            f'pip install "taskspace[{extra}]" (or "taskspace[all]")'
        )


class InvalidInputError(TaskspaceError, ValueError):
    """An argument has the wrong shape, is not finite, or is out of its domain."""


class ShapeError(InvalidInputError):
    """An array has the wrong shape.

    Attributes:
        name: name of the argument.
        expected: expected shape.
        actual: shape that was received.
    """

    def __init__(self, name: str, expected: tuple[int, ...], actual: tuple[int, ...]) -> None:
        self.name = name
        self.expected = expected
        self.actual = actual
        super().__init__(f"{name} must have shape {expected}, got {actual}")


class NotFiniteError(InvalidInputError):
    """An array contains NaN or infinite entries.

    Attributes:
        name: name of the argument.
        indices: indices of the non-finite entries.
    """

    def __init__(self, name: str, indices: Sequence[int]) -> None:
        self.name = name
        self.indices = list(indices)
        super().__init__(f"{name} has non-finite (NaN or inf) entries at indices {self.indices}")


class UnknownNameError(TaskspaceError, KeyError):
    """A robot, frame, joint or other named item does not exist.

    Attributes:
        kind: what was looked up (``"frame"``, ``"joint"``, ``"robot"``...).
        name: the name that was asked for.
        valid: the names that exist.
    """

    def __init__(self, kind: str, name: str, valid: Iterable[str]) -> None:
        self.kind = kind
        self.name = name
        self.valid = sorted(valid)
        super().__init__(kind, name)

    def __str__(self) -> str:
        names = ", ".join(self.valid)
        return f"unknown {self.kind} '{self.name}'; valid {self.kind}s are: {names}"


class ModelLoadError(TaskspaceError):
    """A robot description (URDF, SRDF, registry entry) could not be loaded."""


class LimitError(InvalidInputError):
    """A configuration or command is outside its limits.

    Attributes:
        indices: indices of the offending entries.
        values: their values.
        lower: the lower limits at those indices.
        upper: the upper limits at those indices.
    """

    def __init__(
        self, message: str, indices: Sequence[int], values: Any, lower: Any, upper: Any
    ) -> None:
        self.indices = list(indices)
        self.values = values
        self.lower = lower
        self.upper = upper
        super().__init__(message)


class SolverError(TaskspaceError):
    """A numerical solver failed (QP backend error, no convergence where required)."""


class InfeasibleError(SolverError):
    """A problem has no solution satisfying its hard constraints.

    Attributes:
        culprits: names of the constraints found at fault.
        details: free-form diagnostic data (violations, the QP...).
    """

    def __init__(
        self, message: str, culprits: Sequence[str] = (), details: Any | None = None
    ) -> None:
        self.culprits = list(culprits)
        self.details = details
        super().__init__(message)


class PlanningError(TaskspaceError):
    """A planning query is ill-posed (start or goal in collision, outside bounds...)."""


class CallbackError(TaskspaceError):
    """A user-supplied function (a filter's model, sampler or residual) raised an exception.

    The filters call user functions with arguments they have validated where they can (states,
    covariances) and pass the rest (a measurement ``z``, a control ``u``) through unchanged;
    whatever a user function raises, other than a :class:`TaskspaceError`, is re-raised as
    this error naming the function, with the original exception as ``__cause__``. The
    filter's belief is left unchanged.

    Attributes:
        callback: the name of the user function (e.g. ``"log_likelihood"``).
    """

    def __init__(self, callback: str, exc: BaseException) -> None:
        self.callback = callback
        super().__init__(
            f"the user function {callback} raised {type(exc).__name__}: {exc} (the belief is "
            f"left unchanged; check {callback} and the arguments it was given, e.g. a "
            "measurement or control of another type or shape)"
        )


class StaleModelError(TaskspaceError):
    """An object built from a robot model is used after the model changed.

    Attributes:
        built_version: the :attr:`~taskspace.model.Robot.version` the object was built for.
        current_version: the robot's version now.
    """

    def __init__(self, message: str, built_version: int, current_version: int) -> None:
        self.built_version = built_version
        self.current_version = current_version
        super().__init__(message)


class ConcurrentUseError(TaskspaceError, RuntimeError):
    """An object that is not thread-safe was used by a second thread while in use.

    Raised (instead of a silently mixed-up result) by objects documented "one per thread"
    that detect the overlap, e.g. the Gymnasium environments of
    :mod:`taskspace.learning.envs`.

    Attributes:
        owner: what was shared (class name and method).
    """

    def __init__(self, owner: str) -> None:
        self.owner = owner
        super().__init__(
            f"{owner} was called from a second thread while another call on the same object "
            "was running; it is not thread-safe: give each thread its own object"
        )
