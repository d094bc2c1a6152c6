"""The node model Groot2 needs to open this project's trees, generated from the code.

Groot2 knows BehaviorTree.CPP's own nodes; every other tag a tree uses -- this project's nodes
and py_trees' decorators -- must be declared in a ``<TreeNodesModel>``, with its kind and ports.
As Nav2 ships ``nav2_tree_nodes.xml`` beside its trees, the model is one file beside the trees,
``trees/servicesim_nodes.xml``, that Groot2 imports once for any tree built from these nodes: it
declares every node this project registers and every other tag the trees use. It is generated
from the code, never written by hand: a node's kind comes from its class
(:func:`bt_servicesim.behaviours.node.kind_of`), its ports from its ``INPUT_PORTS`` and
``OUTPUT_PORTS``, and the settings a tree file may give it (``seconds``, ``num_failures``...) from
its constructor's keyword arguments:

    python -m bt_servicesim.tree_model           # rewrite trees/servicesim_nodes.xml
    python -m bt_servicesim.tree_model --check   # exit 1 if it is stale
"""

from __future__ import annotations

import inspect
import re
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import py_trees

from bt_servicesim.behaviours import node_registry
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.tree.files import DEFAULT_TREE

__all__ = ["DEFAULT_NODES", "default_trees", "model_tags", "node_class", "node_model",
           "nodes_file", "used_tags"]

DEFAULT_NODES = DEFAULT_TREE.parent / "servicesim_nodes.xml"
"""The committed node model, beside the trees."""
BTCPP_BUILTINS = frozenset({"Sequence", "Fallback", "Parallel", "SubTree", "BehaviorTree"})
"""Tags Groot2 knows without a model (BehaviorTree.CPP's own)."""
PY_TREES_CONTROLS = {"Selector": py_trees.composites.Selector}
"""py_trees composites the XML parser accepts that BehaviorTree.CPP does not have."""
PROJECT_PACKAGE = "bt_servicesim"
KIND_ORDER = ("Action", "Condition", "Control", "Decorator")
_NOT_SETTINGS = frozenset({"self", "name", "child", "children", "behaviour_class_name"})
_SIMPLE_TYPES = {"int", "float", "str", "bool"}
HEADER = """<?xml version="1.0" encoding="UTF-8"?>
<!--
  The node model of the ServiceSim trees, for Groot2: import this file as the model of any tree
  in this folder. Generated from the code by `python -m bt_servicesim.tree_model`: do not edit
  it by hand (the same command with its check option says whether it is stale).
-->
"""


def default_trees(nodes_file: Path = DEFAULT_NODES) -> list[Path]:
    """Every tree file beside the default node model (the model itself, and ``nodes_file``,
    left out)."""
    skip = {DEFAULT_NODES.resolve(), nodes_file.resolve()}
    return sorted(path for path in DEFAULT_TREE.parent.glob("*.xml") if path.resolve() not in skip)


def used_tags(tree_file: Path) -> set[str]:
    """The tags a tree file uses inside its ``<BehaviorTree>`` elements, BehaviorTree.CPP's own
    left out; ``ValueError`` naming the file if it cannot be read or parsed."""
    try:
        root = ElementTree.parse(tree_file).getroot()
    except OSError as error:
        raise ValueError(f"{tree_file}: {error.strerror or error}") from error
    except ElementTree.ParseError as error:
        raise ValueError(f"{tree_file}: not well-formed XML ({error})") from error
    tags = {element.tag for tree in root.findall("BehaviorTree") for element in tree.iter()}
    return tags - BTCPP_BUILTINS


def model_tags(tree_files: Iterable[Path], registry: Mapping[str, type]) -> set[str]:
    """Every node this project registers, and every other tag the trees use; ``ValueError``
    naming the file for a tag that is no node."""
    tags = {tag for tag, cls in registry.items()
            if cls.__module__.split(".")[0] == PROJECT_PACKAGE}
    for tree_file in tree_files:
        for tag in used_tags(tree_file):
            try:
                node_class(tag, registry)
            except ValueError as error:
                raise ValueError(f"{tree_file}: {error}") from error
            tags.add(tag)
    return tags


def node_class(tag: str, registry: Mapping[str, type]) -> type:
    """The class a tree file's tag builds: a registered node, a py_trees decorator or control;
    ``ValueError`` for any other tag."""
    if tag in registry:
        return registry[tag]
    if tag in PY_TREES_CONTROLS:
        return PY_TREES_CONTROLS[tag]
    candidate = getattr(py_trees.decorators, tag, None)
    if inspect.isclass(candidate) and issubclass(candidate, py_trees.decorators.Decorator):
        return candidate
    raise ValueError(f"unknown tag <{tag}>: neither a registered node nor a py_trees decorator")


def node_model(tag: str, registry: Mapping[str, type]) -> str:
    """One ``<Action|Condition|Control|Decorator ID=…>`` element with its ports."""
    cls = node_class(tag, registry)
    kind = kind_of(cls)
    settings = _settings(cls)
    inputs = getattr(cls, "INPUT_PORTS", {})
    outputs = getattr(cls, "OUTPUT_PORTS", {})
    ports = [_port("input_port", name, _type_name(info.data_type),
                   info.default_value if info.has_default else settings.get(name),
                   info.description)
             for name, info in inputs.items()]
    ports += [_port("output_port", name, _type_name(info.data_type), None, info.description)
              for name, info in outputs.items()]
    ports += [_port("input_port", name, _setting_type(cls, name), default, "")
              for name, default in settings.items() if name not in inputs and name not in outputs]
    if not ports:
        return f'    <{kind} ID="{tag}"/>'
    body = "".join(f"\n      {port}" for port in ports)
    return f'    <{kind} ID="{tag}">{body}\n    </{kind}>'


def nodes_file(tree_files: Iterable[Path], registry: Mapping[str, type] | None = None) -> str:
    """The text of the node model file for ``tree_files``: grouped by kind, then by tag."""
    registry = node_registry() if registry is None else registry
    tags = model_tags(tree_files, registry)
    order = sorted(tags, key=lambda tag: (KIND_ORDER.index(kind_of(node_class(tag, registry))),
                                          tag))
    nodes = "\n".join(node_model(tag, registry) for tag in order)
    return (f'{HEADER}<root BTCPP_format="4">\n  <TreeNodesModel>\n{nodes}\n'
            "  </TreeNodesModel>\n</root>\n")


def _settings(cls: type[object]) -> dict[str, Any]:
    """Constructor keyword arguments a tree file may set as attributes, with their defaults
    (``None`` where there is none worth showing)."""
    settings: dict[str, Any] = {}
    for name, parameter in inspect.signature(cls.__init__).parameters.items():
        if name in _NOT_SETTINGS or parameter.kind in (parameter.VAR_POSITIONAL,
                                                       parameter.VAR_KEYWORD):
            continue
        default = parameter.default
        settings[name] = None if default in (parameter.empty, None, "") else default
    return settings


def _setting_type(cls: type[object], name: str) -> str:
    """A constructor argument's type, when its annotation is a plain ``int``, ``float``..."""
    annotation = inspect.signature(cls.__init__).parameters[name].annotation
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", "")
    return text if text in _SIMPLE_TYPES else ""


def _type_name(data_type: object) -> str:
    """``Pose2D``, ``float``; generics in full without module paths: ``list[Pose2D]``."""
    if getattr(data_type, "__args__", None):
        return re.sub(r"\b[\w.]+\.(\w+)", r"\1", str(data_type))
    return getattr(data_type, "__name__", str(data_type))


def _port(element: str, name: str, type_name: str, default: Any, description: str) -> str:
    attributes = f"name={quoteattr(name)}"
    if type_name:
        attributes += f" type={quoteattr(type_name)}"
    if default is not None:
        attributes += f" default={quoteattr(str(default))}"
    if description:
        return f"<{element} {attributes}>{escape(description)}</{element}>"
    return f"<{element} {attributes}/>"
