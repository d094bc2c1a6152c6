"""Load a mission tree file: BehaviorTree.CPP v4 XML, parsed by py_trees' XML parser.

The tree file is the mission. This module hands the parser the registry of this project's nodes
(:mod:`bt_servicesim.behaviours` registers them all on import), turns the run's settings into the
top-level tree's port values (``time_limit``), and turns every way a tree file can be wrong into
one :class:`MissionTreeError` line that names the file and the problem (the file's structure is
checked by :mod:`bt_servicesim.tree.structure`, its nodes by :mod:`bt_servicesim.tree.validation`).

The Python reads no name that only the tree file defines. What the tools around the tree need
to know of it is declared on the main ``<BehaviorTree>`` as an attribute, beside its ports:
``phases`` names the composite whose children are the mission's phases (BeginTask, Pickup, ...),
which the progress view and the trajectory picture show. A tree that leaves it out gets
:data:`DEFAULT_PHASES`, the shipped tree's; a tree that names a composite it does not have is
refused when it loads, rather than showing no phases later.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import py_trees
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

from bt_servicesim.behaviours import node_registry
from bt_servicesim.tree.files import DEFAULT_TREE
from bt_servicesim.tree.shape import short_label
from bt_servicesim.tree.structure import MissionTreeError, checked_tree_file, main_tree_id
from bt_servicesim.tree.type_hints import hints_per_class
from bt_servicesim.tree.validation import tree_file_problems

PHASES_ATTRIBUTE = "phases"
"""The main tree's attribute naming the composite whose children are the mission's phases."""
DEFAULT_PHASES = "Mission"
"""The phases' composite when the tree does not say: the shipped tree's."""

__all__ = ["DEFAULT_PHASES", "DEFAULT_TREE", "PHASES_ATTRIBUTE", "MissionTreeError",
           "load_mission_tree", "phases_of"]


def load_mission_tree(
    path: str | Path = DEFAULT_TREE,
    *,
    time_limit_s: float | None = None,
    main_tree: str | None = None,
) -> py_trees.behaviour.Behaviour:
    """Parse ``path`` into a py_trees root; ``time_limit_s`` overrides the tree's own default,
    ``main_tree`` names the tree to play instead of the file's ``main_tree_to_execute``."""
    tree_file = Path(path)
    registry = node_registry()
    top = checked_tree_file(tree_file, registry, main_tree=main_tree)
    for problem in tree_file_problems(top, registry):
        raise MissionTreeError(f"{tree_file}: {problem}")
    overrides = None if time_limit_s is None else {"time_limit": repr(float(time_limit_s))}
    try:
        with hints_per_class():
            root = parse_behaviour_tree_xml(
                str(tree_file), main_tree_id=main_tree_id(top, main_tree),
                node_registry=registry, input_mappings=overrides,
            )
    except Exception as error:  # the parser raises many kinds; the user needs one line
        raise MissionTreeError(f"{tree_file}: {_one_line(error)}") from error
    _check_phases(tree_file, root, main_tree)
    return root


def phases_of(path: str | Path = DEFAULT_TREE, *, main_tree: str | None = None) -> str:
    """The name of the composite whose children are the mission's phases, as the tree says."""
    root = ElementTree.parse(path).getroot()
    main = main_tree_id(root, main_tree)
    for tree in root.findall("BehaviorTree"):
        if main is None or tree.get("ID") == main:
            return tree.get(PHASES_ATTRIBUTE, DEFAULT_PHASES)
    return DEFAULT_PHASES


def _check_phases(tree_file: Path, root: py_trees.behaviour.Behaviour,
                  main_tree: str | None) -> None:
    declared = ElementTree.parse(tree_file).getroot().find(
        f"BehaviorTree[@{PHASES_ATTRIBUTE}]")
    if declared is None:
        return
    phases = phases_of(tree_file, main_tree=main_tree)
    if not any(short_label(node.name) == phases and isinstance(node, py_trees.composites.Composite)
               for node in root.iterate()):
        raise MissionTreeError(
            f'{tree_file}: {PHASES_ATTRIBUTE}="{phases}" names no composite of the main tree')



def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= 300 else text[:297] + "..."
