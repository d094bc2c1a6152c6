"""Check a tree file before it runs: what py_trees' parser lets through, found at load time.

The XML parser builds whatever it can. A leaf that leaves out a required input port loads and
then waits on a blackboard key nobody writes, until the mission's time limit; a decorator given
``num_failures="abc"`` loads and then raises inside a tick. Both are mistakes in the file, so
:func:`tree_file_problems` finds them when the tree is loaded, each as one line that names the
node and the attribute:

- every required input port without a default of this project's nodes is given;
- a constructor argument given as a constant (``num_failures="3"``, ``seconds="2.0"``) converts
  to the type the constructor declares (int, float or bool), and so does a constant given to an
  input port declared int or float (``sighting_gap="4.0"``);
- every such number is finite and 0 or more (:func:`number_problem`): each one a tree file
  gives is a time, a distance, a count or a seed. ``nan`` would make every comparison false
  (``<SimWait seconds="nan">`` never ends, ``<RobotInArea margin="nan">`` never holds) and a
  negative count or time ends a node before it starts. The one exception is py_trees' own:
  ``<Repeat num_success="-1">`` repeats for ever (:data:`LOWEST`);
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
import math
import types
import typing
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator, Mapping

import py_trees
from py_trees.ports import PortsMixin

from bt_servicesim.tree.structure import SUBTREE_TAGS, element_label

__all__ = ["LOWEST", "number_problem", "tree_file_problems"]

PARALLEL_POLICIES = ("success_on_all", "success_on_one", "success_on_selected")
WALL_CLOCK_NODES = {"Timeout": "SimTimeout", "Timer": "SimWait"}
"""py_trees' nodes that read the wall clock, each with this project's node on sim time to use
instead. Of what py_trees' XML parser builds, only the ``Timeout`` decorator reads it; its
``Timer`` leaf is refused by name too, in case it is ever registered."""
LOWEST = {("repeat", "num_success"): -1}
"""(lower-case tag, attribute): the lowest number it takes, where that is not 0."""
_NOT_ARGUMENTS = {"name", "child", "children", "behaviour_class_name"}


def tree_file_problems(root: ElementTree.Element,
                       registry: Mapping[str, type]) -> Iterator[str]:
    """One line per problem of the tree file whose top element is ``root``."""
    decorators = _py_trees_decorators()
    for tree in root.findall("BehaviorTree"):
        for element in tree.iter():
            yield from (f"{element_label(element)}: {problem}" for problem
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
    inputs: dict[str, typing.Any] = {}
    if issubclass(cls, PortsMixin):
        inputs = cls.input_ports()
        ports = {**inputs, **cls.output_ports()}
        for name, info in inputs.items():
            if info.required and info.default_value is None and name not in element.attrib:
                yield f"the required input port {name} is not given"
    hints = {name: hint for name, hint in _constructor_hints(cls).items() if name not in ports}
    hints.update(_port_hints(inputs))
    for attribute, value in element.attrib.items():
        expected = hints.get(attribute)
        if attribute in _NOT_ARGUMENTS or _is_key(value) or expected is None:
            continue
        problem = number_problem(value, expected,
                                 lowest=LOWEST.get((element.tag.lower(), attribute), 0))
        if problem is not None:
            yield f'{attribute}="{value}" {problem}'


def number_problem(value: str, expected: type, *, lowest: int = 0) -> str | None:
    """What is wrong with ``value`` as a tree file's ``expected`` (int, float or bool), or None:
    it does not convert, or it is a number that is not finite or below ``lowest``."""
    if not _converts(value, expected):
        article = "an" if expected.__name__[0] in "aeiou" else "a"
        return f"is not {article} {expected.__name__}"
    if expected is bool:
        return None
    number = expected(value)
    if not math.isfinite(number):
        return "is not a finite number"
    if number < lowest:
        below = "negative" if lowest == 0 else f"less than {lowest}"
        return f"is {below}: it must be {lowest} or more"
    return None


def _constructor_hints(cls: type[object]) -> dict[str, type]:
    """The constructor's int, float and bool arguments, by name."""
    try:
        hints = typing.get_type_hints(cls.__init__)
    except (NameError, TypeError):  # hints that do not resolve: nothing to check against
        return {}
    parameters = inspect.signature(cls.__init__).parameters
    return {name: plain for name, hint in hints.items()
            if name in parameters and (plain := _plain_type(hint)) is not None}


def _port_hints(ports: Mapping[str, typing.Any]) -> dict[str, type]:
    """The input ports declared int, float or bool, by name: a constant given them is one."""
    return {name: plain for name, info in ports.items()
            if (plain := _plain_type(info.data_type)) is not None}


def _plain_type(hint: object) -> type | None:
    """int, float or bool for a hint that is one of them (or one of them or None), else None."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        others = [arg for arg in typing.get_args(hint) if arg is not type(None)]
        hint = others[0] if len(others) == 1 else None
    return hint if hint in (int, float, bool) else None


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
