"""A py_trees tree as Groot2 sees a BehaviorTree.CPP one: XML with node uids, status codes.

BehaviorTree.CPP numbers a tree's nodes from 1 in depth-first order, root first, and its
``Groot2Publisher`` serves the tree written back as XML with each node's number in a ``_uid``
attribute; the status buffer and hooks name nodes by that number. :class:`MonitoredTree` does
the same for a py_trees tree: the uid of a behaviour is one more than its position in
:func:`~bt_servicesim.tree.shape.walk` order, which is the order the tree file lists them in.

The tags are what a BehaviorTree.CPP tree of the same behaviour would use, so Groot2 draws
py_trees' composites with its own symbols: a sequence with memory is BehaviorTree.CPP's
``Sequence`` (which resumes its running child), one without is ``ReactiveSequence``, and a
selector ``Fallback`` or ``ReactiveFallback`` alike; a parallel is ``Parallel``. Every other node
is tagged with its class name and declared in the ``<TreeNodesModel>`` with its kind, so a
client that knows nothing of this project still tells actions from conditions. Names are the
short names the terminal view shows (:func:`~bt_servicesim.tree.shape.short_label`).
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import py_trees
from py_trees.common import Status

from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.monitor.groot2_protocol import NodeStatusCode
from bt_servicesim.tree.shape import short_label, walk

__all__ = ["BTCPP_BUILTINS", "STATUS_CODES", "MonitoredTree", "btcpp_tag", "status_codes",
           "tree_xml"]

STATUS_CODES: dict[Status, int] = {
    Status.INVALID: NodeStatusCode.IDLE,
    Status.RUNNING: NodeStatusCode.RUNNING,
    Status.SUCCESS: NodeStatusCode.SUCCESS,
    Status.FAILURE: NodeStatusCode.FAILURE,
}
"""py_trees' statuses as BehaviorTree.CPP's (INVALID, never ticked or stopped, is IDLE)."""
BTCPP_BUILTINS = frozenset({"Sequence", "ReactiveSequence", "Fallback", "ReactiveFallback",
                            "Parallel"})
"""The tags this module uses that Groot2 knows without a model."""


def btcpp_tag(behaviour: py_trees.behaviour.Behaviour) -> str:
    """The tag a BehaviorTree.CPP tree would give ``behaviour`` (see the module docstring)."""
    memory = bool(getattr(behaviour, "memory", False))
    if type(behaviour) is py_trees.composites.Sequence:
        return "Sequence" if memory else "ReactiveSequence"
    if type(behaviour) is py_trees.composites.Selector:
        return "Fallback" if memory else "ReactiveFallback"
    if type(behaviour) is py_trees.composites.Parallel:
        return "Parallel"
    return type(behaviour).__name__


@dataclass(frozen=True)
class MonitoredTree:
    """A tree's behaviours in uid order and the XML that names them."""

    behaviours: tuple[py_trees.behaviour.Behaviour, ...]
    tree_id: str
    xml: str

    @classmethod
    def of(cls, root: py_trees.behaviour.Behaviour, *, tree_id: str | None = None
           ) -> MonitoredTree:
        """``tree_id`` is the ``<BehaviorTree ID>`` (default: the root's short name)."""
        tree_id = tree_id or short_label(root.name)
        return cls(behaviours=tuple(walk(root)), tree_id=tree_id,
                   xml=tree_xml(root, tree_id=tree_id))

    def statuses(self) -> tuple[Status, ...]:
        """Every behaviour's status now, in uid order: the tick's only work for a monitor."""
        return tuple([behaviour.status for behaviour in self.behaviours])


def status_codes(statuses: tuple[Status, ...]) -> list[int]:
    """The status buffer's codes of ``statuses``."""
    return [STATUS_CODES[status] for status in statuses]


def tree_xml(root: py_trees.behaviour.Behaviour, *, tree_id: str) -> str:
    """The tree as BehaviorTree.CPP v4 XML, ``_uid`` on every node, and its node model."""
    lines = ['<root BTCPP_format="4">',
             f'    <BehaviorTree ID={quoteattr(tree_id)} _fullpath="">']
    uid = 0
    models: dict[str, str] = {}

    def element(behaviour: py_trees.behaviour.Behaviour, depth: int) -> None:
        nonlocal uid
        uid += 1
        tag = btcpp_tag(behaviour)
        if tag not in BTCPP_BUILTINS:
            models[tag] = kind_of(type(behaviour))
        opening = f"{'    ' * depth}<{tag} name={quoteattr(short_label(behaviour.name))} " \
                  f'_uid="{uid}"'
        if not behaviour.children:
            lines.append(opening + "/>")
            return
        lines.append(opening + ">")
        for child in behaviour.children:
            element(child, depth + 1)
        lines.append(f"{'    ' * depth}</{tag}>")

    element(root, 2)
    lines += ["    </BehaviorTree>", "    <TreeNodesModel>"]
    lines += [f'        <{kind} ID="{tag}"/>' for tag, kind in sorted(models.items())]
    lines += ["    </TreeNodesModel>", "</root>", ""]
    return "\n".join(lines)
