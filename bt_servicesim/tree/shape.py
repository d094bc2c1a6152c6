"""The tree's shape as plain data, and an inert tree of the same shape to draw statuses on.

A :class:`TreeShape` is a tree's structure -- one :class:`NodeShape` per behaviour, in display
order -- with nothing live in it, so it can be written to a run's snapshot log and read back.
A :class:`ShadowTree` rebuilds it as inert py_trees behaviours of the same kinds, on which any
recorded statuses can be set and drawn: a replay, the live view and ``final_tree.txt`` all
draw exactly what a dump of the live tree draws.

The XML parser qualifies names with their ancestors' (``ServiceSimMission.Mission.Pickup...``),
which keeps them unique but makes a drawing unreadable; a node is labelled with its *short*
name (:func:`short_label`).
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import py_trees
from py_trees.common import Status

NodeState = tuple[Status, str]
"""A node's status and feedback message."""


@dataclass(frozen=True)
class NodeShape:
    """One behaviour as drawn: where it sits and what kind of node it is.

    Attributes:
        key: unique within the tree: the behaviour's full name, ``~2``, ``~3``... when repeated
        label: the short name shown in drawings
        kind: ``sequence``, ``selector``, ``parallel``, ``decorator``, ``composite`` or
            ``behaviour`` (the kinds py_trees draws differently)
        memory: whether a sequence or selector has memory
        parent: index of the parent in :attr:`TreeShape.nodes`, ``None`` for the root
        type: the behaviour's class name (``Retry``, ``RecoveryNode``, a leaf's ports class);
            empty in a log written before it was kept
    """

    key: str
    label: str
    kind: str
    memory: bool
    parent: int | None
    type: str = ""


@dataclass(frozen=True)
class TreeShape:
    """A tree's structure as plain data, root first, children in order (pre-order)."""

    nodes: tuple[NodeShape, ...]

    @classmethod
    def of(cls, root: py_trees.behaviour.Behaviour) -> TreeShape:
        behaviours = walk(root)
        index = {id(behaviour): position for position, behaviour in enumerate(behaviours)}
        keys = unique_keys(behaviours)
        return cls(nodes=tuple(
            NodeShape(
                key=key, label=short_label(behaviour.name), kind=kind_of(behaviour),
                memory=bool(getattr(behaviour, "memory", False)),
                parent=None if behaviour.parent is None or behaviour is root
                else index[id(behaviour.parent)],
                type=type(behaviour).__name__,
            )
            for behaviour, key in zip(behaviours, keys, strict=True)
        ))

    def to_json(self) -> list[dict[str, Any]]:
        return [asdict(node) for node in self.nodes]

    @classmethod
    def from_json(cls, nodes: Sequence[Mapping[str, Any]]) -> TreeShape:
        """The inverse of :meth:`to_json`; raises ``ValueError`` on a malformed list."""
        try:
            shapes = tuple(
                NodeShape(key=str(node["key"]), label=str(node["label"]), kind=str(node["kind"]),
                          memory=bool(node["memory"]),
                          parent=None if node["parent"] is None else int(node["parent"]),
                          type=str(node.get("type", "")))
                for node in nodes
            )
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"malformed tree shape ({error})") from error
        if not shapes or shapes[0].parent is not None or any(
            node.parent is None or not 0 <= node.parent < position
            for position, node in enumerate(shapes[1:], start=1)
        ):
            raise ValueError("malformed tree shape (parents must come before their children)")
        return cls(nodes=shapes)

    @property
    def keys(self) -> list[str]:
        return [node.key for node in self.nodes]


def walk(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    """Every behaviour under ``root``, root first, children in order."""
    behaviours = [root]
    for child in root.children:
        behaviours.extend(walk(child))
    return behaviours


def unique_keys(behaviours: Sequence[py_trees.behaviour.Behaviour]) -> list[str]:
    seen: dict[str, int] = {}
    keys = []
    for behaviour in behaviours:
        seen[behaviour.name] = seen.get(behaviour.name, 0) + 1
        count = seen[behaviour.name]
        keys.append(behaviour.name if count == 1 else f"{behaviour.name}~{count}")
    return keys


def short_label(name: str) -> str:
    """``A.B.Leaf`` is drawn as ``Leaf`` (the XML parser's qualification dropped)."""
    return name.rsplit(".", 1)[-1].replace("\n", " ")


def kind_of(behaviour: py_trees.behaviour.Behaviour) -> str:
    if isinstance(behaviour, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(behaviour, py_trees.decorators.Decorator):
        return "decorator"
    if isinstance(behaviour, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(behaviour, py_trees.composites.Selector):
        return "selector"
    if isinstance(behaviour, py_trees.composites.Composite):
        return "composite"
    return "behaviour"


class _InertLeaf(py_trees.behaviour.Behaviour):
    """A leaf that is only ever drawn, never ticked."""

    def update(self) -> Status:
        return self.status


class _InertComposite(py_trees.composites.Composite):
    """A composite of a kind py_trees has no symbol for (drawn like a leaf, as py_trees does)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        yield self


class ShadowTree:
    """Inert py_trees behaviours in a tree's shape, holding statuses copied from elsewhere."""

    def __init__(self, shape: TreeShape) -> None:
        self.shape = shape
        self.behaviours: list[py_trees.behaviour.Behaviour] = []
        children: dict[int, list[py_trees.behaviour.Behaviour]] = {}
        for position in reversed(range(len(shape.nodes))):  # children before their parents
            node = shape.nodes[position]
            behaviour = _shadow_behaviour(node, children.pop(position, []))
            self.behaviours.append(behaviour)
            if node.parent is not None:
                children.setdefault(node.parent, []).insert(0, behaviour)
        self.behaviours.reverse()
        self.root = self.behaviours[0]
        self._index = {key: position for position, key in enumerate(shape.keys)}

    def show(self, states: Mapping[str, NodeState], *, tip: str | None = None) -> None:
        """Give every node its logged status and feedback (INVALID when absent)."""
        for key, behaviour in zip(self.shape.keys, self.behaviours, strict=True):
            behaviour.status, behaviour.feedback_message = states.get(key, (Status.INVALID, ""))
        self._point_at(tip)

    def copy_from(self, live: Sequence[py_trees.behaviour.Behaviour]) -> None:
        """Copy statuses and feedback from the live behaviours (in :func:`walk` order)."""
        for shadow, behaviour in zip(self.behaviours, live, strict=True):
            shadow.status, shadow.feedback_message = behaviour.status, behaviour.feedback_message
        tip = live[0].tip()
        self._point_at(None if tip is None else self.shape.keys[_position(live, tip)])

    def _point_at(self, tip: str | None) -> None:
        """Make the composites on the way to ``tip`` point at it, so py_trees marks it."""
        for behaviour in self.behaviours:
            if isinstance(behaviour, py_trees.composites.Composite):
                behaviour.current_child = None
        position = self._index.get(tip) if tip is not None else None
        while position is not None:
            parent = self.shape.nodes[position].parent
            if parent is not None:
                composite = self.behaviours[parent]
                if isinstance(composite, py_trees.composites.Composite):
                    composite.current_child = self.behaviours[position]
            position = parent

    def text(self, *, symbols: str = "unicode", show_status: bool = True,
             running_only: bool = False, colour: bool = False) -> str:
        """Draw the tree with py_trees' ascii or unicode art.

        Args:
            symbols: ``"unicode"`` or ``"ascii"``
            show_status: every node's status and feedback message, not just its name
            running_only: expand only RUNNING branches (the rest end in ``...``)
            colour: keep the terminal's escape codes (bold tip, coloured statuses)
        """
        draw = py_trees.display.ascii_tree if symbols == "ascii" else py_trees.display.unicode_tree
        expanded = {
            behaviour.id: behaviour.status for behaviour in self.behaviours
            if behaviour is self.root or behaviour.status == Status.RUNNING
        }
        drawing = draw(self.root, show_only_visited=running_only, show_status=show_status,
                       visited=expanded if running_only else None)
        return drawing if colour else plain(drawing)


def _shadow_behaviour(node: NodeShape,
                      children: list[py_trees.behaviour.Behaviour]) -> py_trees.behaviour.Behaviour:
    name = node.label
    if node.kind == "sequence":
        return py_trees.composites.Sequence(name=name, memory=node.memory, children=children)
    if node.kind == "selector":
        return py_trees.composites.Selector(name=name, memory=node.memory, children=children)
    if node.kind == "parallel":
        return py_trees.composites.Parallel(
            name=name, policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=children)
    if node.kind == "decorator" and len(children) == 1:
        return py_trees.decorators.PassThrough(name=name, child=children[0])
    if children:
        return _InertComposite(name=name, children=children)
    return _InertLeaf(name=name)


def _position(behaviours: Sequence[py_trees.behaviour.Behaviour],
              wanted: py_trees.behaviour.Behaviour) -> int:
    return next(index for index, behaviour in enumerate(behaviours) if behaviour is wanted)


_ESCAPE_CODE = re.compile(r"\x1b\[[0-9;]*m")


def plain(text: str) -> str:
    """``text`` without terminal escape codes."""
    return _ESCAPE_CODE.sub("", text)
