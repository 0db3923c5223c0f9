"""Every public class states its thread safety (#15 Build 5: "document thread-safety of every
public object").

The classes are those exported (``__all__``) by taskspace's subpackages, searched recursively
(``taskspace.learning.envs`` too), and :class:`taskspace.tasks.Task`. A class states it when
its docstring or the docstring of the module that defines it has a "Thread safety" paragraph
(modules of plain values say it once for all their classes).

``PENDING`` lists, by name, the classes of the modules other helpers are working on that do not
state it yet; the lead removes entries as their modules get the statement. A class outside
``PENDING`` without the statement fails the test, so does a ``PENDING`` entry that is not an
exported class (a typo would hide nothing).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
from collections.abc import Iterator
from types import ModuleType

import taskspace

STATEMENT = re.compile(r"thread[ -]safety", re.IGNORECASE)
EXTRA_MODULES = {"taskspace.tasks": ("Task",)}
"""Public top-level modules without ``__all__`` and the classes they export."""

PENDING: frozenset[str] = frozenset()


def _subpackages(package: ModuleType) -> Iterator[ModuleType]:
    for info in pkgutil.iter_modules(package.__path__):
        if info.ispkg and not info.name.startswith("_"):
            module = importlib.import_module(f"{package.__name__}.{info.name}")
            yield module
            yield from _subpackages(module)


def public_classes() -> dict[str, type]:
    """``exporting module.name -> class`` for every exported class."""
    found: dict[str, type] = {}
    modules = [(m, list(getattr(m, "__all__", ()))) for m in _subpackages(taskspace)]
    modules += [(importlib.import_module(m), list(n)) for m, n in EXTRA_MODULES.items()]
    for module, names in modules:
        for name in names:
            obj = getattr(module, name)
            if inspect.isclass(obj):
                found[f"{module.__name__}.{name}"] = obj
    return found


def states_thread_safety(cls: type) -> bool:
    """The class's docstring or its defining module's says "Thread safety"."""
    module = sys.modules.get(cls.__module__)
    texts = [cls.__doc__ or "", (module.__doc__ if module is not None else None) or ""]
    return any(STATEMENT.search(text) for text in texts)


def test_every_public_class_states_its_thread_safety() -> None:
    classes = public_classes()
    assert len(classes) > 300  # the walk found the subpackages (not an empty pass)
    missing = sorted(
        f"{name} (defined in {cls.__module__})"
        for name, cls in classes.items()
        if name not in PENDING and not states_thread_safety(cls)
    )
    assert not missing, (
        "public classes without a 'Thread safety' statement in their docstring or their "
        "module's (add one: immutable, per-call workspace, lock, or one per thread):\n  "
        + "\n  ".join(missing)
    )


def test_pending_entries_are_exported_classes() -> None:
    unknown = sorted(PENDING - set(public_classes()))
    assert not unknown, f"PENDING names no exported class: {unknown}"


def test_the_check_sees_a_class_without_the_statement() -> None:
    # The predicate itself: a class (and module) without the words fails, with them passes.
    class Undocumented:
        """A workspace."""

    class Documented:
        """A workspace.

        Thread safety: one per thread.
        """

    saved = sys.modules[__name__].__doc__
    try:
        sys.modules[__name__].__doc__ = "no statement here"
        assert not states_thread_safety(Undocumented)
        assert states_thread_safety(Documented)
    finally:
        sys.modules[__name__].__doc__ = saved
