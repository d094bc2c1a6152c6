"""Check a tree file before it runs: what py_trees' parser lets through, found at load time.

The XML parser builds whatever it can. A leaf that leaves out a required input port loads and
then waits on a blackboard key nobody writes, until the mission's time limit; a decorator given
``num_failures="abc"`` loads and then raises inside a tick. Both are mistakes in the file, so
:func:`tree_file_problems` finds them when the tree is loaded, each as one line that names the
node and the attribute:

- every required input port without a default of this project's nodes is given;
- a constructor argument given as a constant (``num_failures="3"``, ``seconds="2.0"``) converts
  to the type the constructor declares (int, float or bool);
- ``memory`` of a Sequence or Fallback is ``true`` or ``false``; ``policy`` of a Parallel is one
  py_trees knows.
"""

from __future__ import annotations

import inspect
import typing
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator, Mapping

import py_trees
from py_trees.ports import PortsMixin

__all__ = ["tree_file_problems"]

PARALLEL_POLICIES = ("success_on_all", "success_on_one", "success_on_selected")
_NOT_ARGUMENTS = {"name", "child", "children", "behaviour_class_name"}


def tree_file_problems(root: ElementTree.Element,
                       registry: Mapping[str, type]) -> Iterator[str]:
    """One line per problem of the tree file whose top element is ``root``."""
    decorators = _py_trees_decorators()
    for tree in root.findall("BehaviorTree"):
        for element in tree.iter():
            where = f"<{element.tag} name=\"{element.get('name', '')}\">"
            cls = registry.get(element.tag) or decorators.get(element.tag.lower())
            if cls is not None:
                yield from (f"{where}: {problem}" for problem in _node_problems(element, cls))
            elif element.tag.lower() in ("sequence", "fallback", "selector"):
                memory = element.get("memory", "true").lower()
                if memory not in ("true", "false"):
                    yield f'{where}: memory="{element.get("memory")}" is not true or false'
            elif element.tag.lower() == "parallel":
                policy = element.get("policy", "success_on_one")
                if policy not in PARALLEL_POLICIES:
                    yield (f'{where}: policy="{policy}" is not one of '
                           f"{', '.join(PARALLEL_POLICIES)}")


def _node_problems(element: ElementTree.Element, cls: type) -> Iterator[str]:
    ports: dict[str, typing.Any] = {}
    if issubclass(cls, PortsMixin):
        ports = {**cls.input_ports(), **cls.output_ports()}
        for name, info in cls.input_ports().items():
            if info.required and info.default_value is None and name not in element.attrib:
                yield f"the required input port {name} is not given"
    hints = _constructor_hints(cls)
    for attribute, value in element.attrib.items():
        if attribute in ports or attribute in _NOT_ARGUMENTS or _is_key(value):
            continue
        expected = hints.get(attribute)
        if expected is not None and not _converts(value, expected):
            article = "an" if expected.__name__[0] in "aeiou" else "a"
            yield f'{attribute}="{value}" is not {article} {expected.__name__}'


def _constructor_hints(cls: type) -> dict[str, type]:
    """The constructor's int, float and bool arguments, by name."""
    try:
        hints = typing.get_type_hints(cls.__init__)
    except (NameError, TypeError):  # hints that do not resolve: nothing to check against
        return {}
    parameters = inspect.signature(cls.__init__).parameters
    return {name: hint for name, hint in hints.items()
            if name in parameters and hint in (int, float, bool)}


def _converts(value: str, expected: type) -> bool:
    if expected is bool:
        return value.strip().lower() in ("true", "false", "1", "0")
    try:
        expected(value)
    except ValueError:
        return False
    return True


def _is_key(value: str) -> bool:
    return value.startswith("{") and value.endswith("}")


def _py_trees_decorators() -> dict[str, type]:
    """py_trees' decorators by lower-case tag, as its XML parser looks them up."""
    return {name.lower(): cls for name, cls in inspect.getmembers(py_trees.decorators,
                                                                  inspect.isclass)
            if issubclass(cls, py_trees.decorators.Decorator)
            and cls is not py_trees.decorators.Decorator}
