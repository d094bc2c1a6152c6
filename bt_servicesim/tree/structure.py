"""Check a tree file's structure before it loads: which trees it holds and how they fit.

py_trees' XML parser takes the structure on trust. Two ``<BehaviorTree ID="Sub">`` in one file
load, and the second wins silently; a leaf given a child element loads without it; a SubTree
cycle (A uses B, B uses A) recurses until Python's recursion limit; a file of several trees that
does not say which is the main one fails with "BehaviorTree with ID 'None' not found". Each is a
mistake in the file, so :func:`structure_problems` finds it first, as one line naming the element
and the problem, as BehaviorTree.CPP's own loader refuses it:

- every ``<BehaviorTree>`` has an ``ID`` no other has, and exactly one child (its root node);
- the main tree is named by ``main_tree_to_execute`` (or by the caller), or is the only tree;
- every ``<SubTree>`` names by its ``ID`` a tree of the file, and has no child element;
- no tree uses itself, through any chain of SubTrees;
- a leaf (a registered node that is neither a decorator nor a control) has no child element,
  a decorator exactly one.

Only the last needs to know the nodes, from the registry that importing every behaviour makes.
:func:`checked_tree_file` runs the others with an empty registry, which imports nothing: a
command checks them before it starts what the tree would need (the run, its simulator).
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator, Mapping
from pathlib import Path

import py_trees

__all__ = [
    "SUBTREE_TAGS", "MissionTreeError", "checked_tree_file", "element_label", "main_tree_id",
    "structure_problems",
]

SUBTREE_TAGS = ("subtree", "subtreeplus")


class MissionTreeError(ValueError):
    """A tree file that cannot be loaded; the message is one line naming the file and problem."""


def checked_tree_file(tree_file: Path, registry: Mapping[str, type] | None = None, *,
                      main_tree: str | None = None) -> ElementTree.Element:
    """The top element of ``tree_file``, a file of well-formed XML, a ``<root>`` with a tree in
    it and none of the problems :func:`structure_problems` finds with ``registry`` (with none,
    those that need no node's class); else :class:`MissionTreeError` naming the first."""
    if not tree_file.is_file():
        what = "is a directory, not a tree file" if tree_file.is_dir() else "no such tree file"
        raise MissionTreeError(f"{tree_file}: {what}")
    try:
        root = ElementTree.parse(tree_file).getroot()
    except ElementTree.ParseError as error:
        raise MissionTreeError(f"{tree_file}: not well-formed XML ({error})") from error
    if root.tag != "root":
        raise MissionTreeError(f"{tree_file}: the top element is <{root.tag}>, expected <root>")
    if root.find("BehaviorTree") is None:
        raise MissionTreeError(f"{tree_file}: no <BehaviorTree> element")
    for problem in structure_problems(root, registry or {}, main_tree=main_tree):
        raise MissionTreeError(f"{tree_file}: {problem}")
    return root


def main_tree_id(root: ElementTree.Element, given: str | None = None) -> str | None:
    """The main tree's ID: ``given``, else the file's ``main_tree_to_execute``, else that of
    the file's only tree; None when the file holds several and names none."""
    if given is not None:
        return given
    named = root.get("main_tree_to_execute")
    if named is not None:
        return named
    trees = root.findall("BehaviorTree")
    return trees[0].get("ID") if len(trees) == 1 else None


def structure_problems(root: ElementTree.Element, registry: Mapping[str, type], *,
                       main_tree: str | None = None) -> Iterator[str]:
    """One line per problem of the structure of the tree file whose top element is ``root``;
    ``main_tree`` is the main tree's ID when the caller names it."""
    trees = root.findall("BehaviorTree")
    yield from _identity_problems(trees)
    ids = {tree_id for tree in trees if (tree_id := tree.get("ID")) is not None}
    yield from _main_tree_problems(root, ids=ids, count=len(trees), given=main_tree)
    for tree in trees:
        for element in tree.iter():
            yield from _children_problems(element, registry=registry, ids=ids)
    cycle = _subtree_cycle(trees)
    if cycle:
        yield f"a SubTree cycle: {' -> '.join(cycle)} (a tree may not use itself)"


def _identity_problems(trees: list[ElementTree.Element]) -> Iterator[str]:
    seen: set[str] = set()
    for position, tree in enumerate(trees, start=1):
        tree_id = tree.get("ID")
        if not tree_id:
            yield f"<BehaviorTree> number {position} has no ID"
        elif tree_id in seen:
            yield (f'two <BehaviorTree ID="{tree_id}">: each tree needs an ID of its own '
                   "(the parser would keep the second silently)")
        seen.add(tree_id or "")
        if len(tree) != 1:
            yield (f'<BehaviorTree ID="{tree_id}"> has {len(tree)} child elements: a tree '
                   "has exactly one, its root node")


def _main_tree_problems(root: ElementTree.Element, *, ids: set[str], count: int,
                        given: str | None) -> Iterator[str]:
    main = main_tree_id(root, given)
    if main is None:
        yield (f"{count} trees and no main_tree_to_execute: name the main tree with "
               '<root main_tree_to_execute="ID">')
    elif main not in ids:
        where = "the main tree" if given is not None else f'main_tree_to_execute="{main}"'
        yield f"{where} names no <BehaviorTree> of the file (it has {_listed(ids)})"


def _children_problems(element: ElementTree.Element, *, registry: Mapping[str, type],
                       ids: set[str]) -> Iterator[str]:
    tag = element.tag.lower()
    where, children = element_label(element), len(element)
    if tag in SUBTREE_TAGS:
        subtree = element.get("ID")
        if not subtree:
            yield f"{where}: a SubTree needs an ID, the <BehaviorTree> it plays"
        elif subtree not in ids:
            yield f"{where}: names no <BehaviorTree> of the file (it has {_listed(ids)})"
        if children:
            yield f"{where}: a SubTree takes no child elements; it has {children}"
        return
    cls = registry.get(element.tag)
    if cls is None:
        return
    if issubclass(cls, py_trees.decorators.Decorator):
        if children != 1:
            yield f"{where}: a decorator takes exactly one child; it has {children}"
    elif not issubclass(cls, py_trees.composites.Composite) and children:
        more = f" and {children - 1} more" if children > 1 else ""
        yield f"{where}: a leaf takes no child elements; it has <{element[0].tag}>{more}"


def _subtree_cycle(trees: list[ElementTree.Element]) -> list[str]:
    """The first chain of tree IDs that comes back to where it started, or []."""
    uses = {tree.get("ID", ""): [element.get("ID", "") for element in tree.iter()
                                  if element.tag.lower() in SUBTREE_TAGS and element.get("ID")]
            for tree in trees}
    finished: set[str] = set()

    def visit(tree_id: str, path: list[str]) -> list[str]:
        if tree_id in path:
            return [*path[path.index(tree_id):], tree_id]
        if tree_id in finished or tree_id not in uses:
            return []
        for used in uses[tree_id]:
            cycle = visit(used, [*path, tree_id])
            if cycle:
                return cycle
        finished.add(tree_id)
        return []

    for tree_id in uses:
        cycle = visit(tree_id, [])
        if cycle:
            return cycle
    return []


def element_label(element: ElementTree.Element) -> str:
    """The element by its name, or when it has none by all its attributes."""
    shown = {"name": element.attrib["name"]} if "name" in element.attrib else element.attrib
    attributes = "".join(f' {key}="{value}"' for key, value in shown.items())
    return f"<{element.tag}{attributes}>"


def _listed(ids: set[str]) -> str:
    return ", ".join(sorted(ids)) or "none"
