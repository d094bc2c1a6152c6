"""py_trees' type hints of each node class, worked out once per class rather than once per node.

Design intent: py_trees' XML parser converts every attribute of a node to the type its
constructor declares (``py_trees.ports_utils.apply_type_hints``). To find that type it collects
the hints of every ``__init__`` in the class's method resolution order, for every node it builds
(``py_trees.ports_utils.collect_type_hints``), and ``inspect.signature`` of ``object.__init__``,
at the end of every such order, parses its text signature with Python's tokenizer each time.
That is half or more of the time it takes to load the mission tree (a couple of hundred
nodes), which every run and every warm episode of an evaluation does.

A class's constructor, and so its hints, do not change while the process runs. While
:func:`hints_per_class` is in effect the parser takes them from :data:`_HINTS`, filled by
py_trees' own function: the same hints, so every conversion, warning and error is py_trees'.
Only the parse of one tree at a time, in the thread that loads it, sees the change; py_trees'
function is put back when the parse ends. A py_trees without that function parses as it is.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from py_trees import ports_utils

__all__ = ["hints_per_class"]

_COLLECT: Callable[[Callable[..., Any]], dict[str, Any]] | None = getattr(
    ports_utils, "collect_type_hints", None)
_HINTS: dict[object, dict[str, Any]] = {}
"""The hints py_trees collected, by class (or callable); the parser only reads them."""


def _kept(collect: Callable[[Callable[..., Any]], dict[str, Any]],
          ) -> Callable[[Callable[..., Any]], dict[str, Any]]:
    """``collect`` (py_trees' function), asked once per class."""
    def kept_hints(constructor: Callable[..., Any]) -> dict[str, Any]:
        try:
            return _HINTS[constructor]
        except KeyError:
            hints = _HINTS[constructor] = collect(constructor)
            return hints
        except TypeError:  # a callable that cannot be a key: worked out each time
            return collect(constructor)
    return kept_hints


@contextmanager
def hints_per_class() -> Iterator[None]:
    """While in effect, py_trees' parser collects each class's type hints once."""
    collect = _COLLECT
    if collect is None or ports_utils.collect_type_hints is not collect:
        yield  # another py_trees, or a parse within a parse: nothing to change
        return
    ports_utils.collect_type_hints = _kept(collect)  # type: ignore[assignment]  # same signature
    try:
        yield
    finally:
        ports_utils.collect_type_hints = collect
