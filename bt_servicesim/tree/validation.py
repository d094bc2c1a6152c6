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

It also refuses what would make a mission read the wall clock or differ from one load to the
next, since a seed has to replay the same mission:

- py_trees' wall-clock nodes (:data:`WALL_CLOCK_NODES`: the ``Timeout`` decorator, and the
  ``Timer`` leaf should it ever be registered), each with the sim-time node to use instead;
- a ``<SubTree>`` without a ``name``, and a node that seeds itself from its name (one taking a
  ``seed``, such as JitterGoal) given neither a name nor a seed: py_trees names those with a
  random uuid, so their qualified names and those of the nodes under them, and the seeds
  derived from them, would change on every load.
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
WALL_CLOCK_NODES = {"Timeout": "SimTimeout", "Timer": "SimWait"}
"""py_trees' nodes that read the wall clock, each with this project's node on sim time to use
instead. Of what py_trees' XML parser builds, only the ``Timeout`` decorator reads it; its
``Timer`` leaf is refused by name too, in case it is ever registered."""
SUBTREE_TAGS = ("subtree", "subtreeplus")
_NOT_ARGUMENTS = {"name", "child", "children", "behaviour_class_name"}


def tree_file_problems(root: ElementTree.Element,
                       registry: Mapping[str, type]) -> Iterator[str]:
    """One line per problem of the tree file whose top element is ``root``."""
    decorators = _py_trees_decorators()
    for tree in root.findall("BehaviorTree"):
        for element in tree.iter():
            yield from (f"{_where(element)}: {problem}" for problem
                        in _element_problems(element, registry=registry, decorators=decorators))


def _element_problems(element: ElementTree.Element, *, registry: Mapping[str, type],
                      decorators: Mapping[str, type]) -> Iterator[str]:
    tag = element.tag.lower()
    cls = registry.get(element.tag) or decorators.get(tag)
    wall_clock = _wall_clock_node(element.tag, registry=registry)
    if wall_clock is not None:
        yield (f"py_trees' {wall_clock} runs on the wall clock, which a replay does not "
               f"repeat: use {WALL_CLOCK_NODES[wall_clock]}, on sim time")
    elif cls is not None:
        yield from _node_problems(element, cls)
    elif tag in SUBTREE_TAGS and not element.get("name"):
        yield ("a SubTree needs a name: py_trees names it with a random uuid, and the names "
               "under it (and the seeds JitterGoal derives from them) would change every load")
    elif tag in ("sequence", "fallback", "selector"):
        memory = element.get("memory", "true").lower()
        if memory not in ("true", "false"):
            yield f'memory="{element.get("memory")}" is not true or false'
    elif tag == "parallel":
        policy = element.get("policy", "success_on_one")
        if policy not in PARALLEL_POLICIES:
            yield f'policy="{policy}" is not one of {", ".join(PARALLEL_POLICIES)}'


def _where(element: ElementTree.Element) -> str:
    """The element by its name, or when it has none by all its attributes."""
    shown = {"name": element.attrib["name"]} if "name" in element.attrib else element.attrib
    attributes = "".join(f' {key}="{value}"' for key, value in shown.items())
    return f"<{element.tag}{attributes}>"


def _wall_clock_node(tag: str, *, registry: Mapping[str, type]) -> str | None:
    """py_trees' wall-clock node that ``tag`` builds (its parser matches decorators in any
    case), or None; a node of this project's registry under that tag is this project's."""
    if tag in registry:
        return None
    return next((name for name in WALL_CLOCK_NODES if name.lower() == tag.lower()), None)


def _node_problems(element: ElementTree.Element, cls: type) -> Iterator[str]:
    if _seeds_from_name(cls) and not element.get("name") and "seed" not in element.attrib:
        yield ("needs a name or a seed: py_trees names it with a random uuid, and it seeds "
               "itself from its name, so each load would draw different numbers")
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


def _constructor_hints(cls: type[object]) -> dict[str, type]:
    """The constructor's int, float and bool arguments, by name."""
    try:
        hints = typing.get_type_hints(cls.__init__)
    except (NameError, TypeError):  # hints that do not resolve: nothing to check against
        return {}
    parameters = inspect.signature(cls.__init__).parameters
    return {name: hint for name, hint in hints.items()
            if name in parameters and hint in (int, float, bool)}


def _seeds_from_name(cls: type[object]) -> bool:
    """Whether ``cls`` takes a ``seed`` and so, given none, seeds itself from its name."""
    try:
        return "seed" in inspect.signature(cls.__init__).parameters
    except (TypeError, ValueError):  # no signature to read
        return False


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
