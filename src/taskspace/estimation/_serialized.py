"""One lock per stateful estimator: its calls that read and write the belief run one at a time.

A filter shared by threads (a sensor callback updating while a timer predicts) lost updates
without it: two calls read the same belief and the second write dropped the first. With the
lock every ``predict`` / ``update`` / ``step`` / ``run`` is atomic (in some order); for
parallel filtering use one estimator per thread.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


def serialized(method: F) -> F:
    """Run ``method`` holding ``self._lock`` (a :class:`threading.RLock`)."""

    @functools.wraps(method)
    def locked(self: Any, *args: Any, **kwargs: Any) -> Any:
        with self._lock:
            return method(self, *args, **kwargs)

    return locked  # type: ignore[return-value]
