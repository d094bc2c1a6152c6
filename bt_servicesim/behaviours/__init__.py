"""The mission tree's own nodes; importing this package registers every one as an XML tag.

The folder says what a node is, as in Nav2's ``plugins/``: ``actions/``, ``conditions/``,
``decorators/`` and ``controls/``; the base class says it too
(:mod:`bt_servicesim.behaviours.node`), and the generated node model reads it from there. py_trees
registers a behaviour with ports under its class name when the class is defined, so importing every
module below is all it takes: no list of leaves to keep in step by hand.
"""

from __future__ import annotations

import importlib
import pkgutil

import py_trees

__all__ = ["node_registry"]


def _import_all() -> None:
    for module in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
        importlib.import_module(module.name)


def node_registry() -> dict[str, type]:
    """py_trees' registry of XML tags, with every node of this package in it."""
    return py_trees.ports.get_ports_registry()


_import_all()
