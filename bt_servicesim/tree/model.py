"""Keep a tree file's ``<TreeNodesModel>`` in step with the behaviours, so Groot2 opens it.

Groot2 knows BehaviorTree.CPP's own nodes; every other tag a file uses — this project's leaves
and the py_trees decorators — must be declared in a ``<TreeNodesModel>`` with its ports. The
model is generated from the code (the ports registry and the decorators' constructor
arguments), never written by hand:

    python -m bt_servicesim.tree_model trees/servicesim_mission.xml          # rewrite in place
    python -m bt_servicesim.tree_model --check trees/servicesim_mission.xml  # exit 1 if stale
"""

from __future__ import annotations

import inspect
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import py_trees

from bt_servicesim.behaviours import node_registry
from bt_servicesim.behaviours.node import kind_of

MODEL_PATTERN = re.compile(r"\n?[ \t]*<TreeNodesModel>.*?</TreeNodesModel>[ \t]*\n?", re.DOTALL)
BTCPP_BUILTINS = {"Sequence", "Fallback", "Parallel", "SubTree", "BehaviorTree", "root",
                  "TreeNodesModel"}


def used_tags(tree_file: Path) -> list[str]:
    root = ElementTree.parse(tree_file).getroot()
    tags = {element.tag for tree in root.findall("BehaviorTree") for element in tree.iter()}
    return sorted(tags - BTCPP_BUILTINS)


def _decorator_class(tag: str) -> type | None:
    candidate = getattr(py_trees.decorators, tag, None)
    return candidate if inspect.isclass(candidate) else None


def _type_name(data_type: object) -> str:
    """``Pose2D``, ``float``; generics in full without module paths: ``list[Pose2D]``."""
    if getattr(data_type, "__args__", None):
        return re.sub(r"\b[\w.]+\.(\w+)", r"\1", str(data_type))
    return getattr(data_type, "__name__", str(data_type))


def node_model(tag: str, registry: dict[str, type]) -> str:
    """One ``<Action|Condition|Decorator ID=…>`` element with its ports."""
    if tag in registry:
        cls = registry[tag]
        kind = kind_of(cls)
        ports = [f'<input_port name="{name}" type="{_type_name(info.data_type)}"/>'
                 for name, info in cls.input_ports().items()]
        ports += [f'<output_port name="{name}" type="{_type_name(info.data_type)}"/>'
                  for name, info in cls.output_ports().items()]
        ports += [f'<input_port name="{name}"/>' for name in _extra_arguments(cls)
                  if name not in cls.input_ports()]
    else:
        cls = _decorator_class(tag)
        if cls is None:
            raise ValueError(f"unknown tag <{tag}>: neither a behaviour nor a py_trees decorator")
        kind = "Decorator"
        ports = [f'<input_port name="{name}"/>' for name in _extra_arguments(cls)]
    body = "".join(f"\n      {port}" for port in ports)
    return f'    <{kind} ID="{tag}">{body}\n    </{kind}>' if ports else f'    <{kind} ID="{tag}"/>'


def _extra_arguments(cls: type) -> list[str]:
    """Constructor keyword arguments a tree file may set as attributes (``seconds``, ...)."""
    skip = {"self", "name", "child", "children", "behaviour_class_name", "args", "kwargs"}
    parameters = inspect.signature(cls.__init__).parameters
    return [name for name in parameters if name not in skip]


def model_for(tree_file: Path) -> str:
    registry = node_registry()
    nodes = "\n".join(node_model(tag, registry) for tag in used_tags(tree_file))
    return f"  <TreeNodesModel>\n{nodes}\n  </TreeNodesModel>\n"


def with_model(text: str, model: str) -> str:
    """The file's text with its model replaced (or added before ``</root>``)."""
    head, tail = MODEL_PATTERN.sub("\n", text).rsplit("</root>", 1)
    return head.rstrip() + "\n\n" + model + "\n</root>" + tail
