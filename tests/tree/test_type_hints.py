"""The tree loader has py_trees' XML parser collect each node class's type hints once: the
same hints and the same conversions as py_trees' own function, which is back in place after
every parse, a failed one too."""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path
from typing import Any

import pytest
from py_trees import ports_utils

from bt_servicesim.behaviours import node_registry
from bt_servicesim.tree.loading import DEFAULT_TREE, MissionTreeError, load_mission_tree
from bt_servicesim.tree.type_hints import hints_per_class

PY_TREES_COLLECT = ports_utils.collect_type_hints


def test_every_registered_node_gets_py_trees_own_hints() -> None:
    registry = node_registry()
    with hints_per_class():
        assert ports_utils.collect_type_hints is not PY_TREES_COLLECT
        for tag, constructor in registry.items():
            kept = ports_utils.collect_type_hints(constructor)
            assert kept == PY_TREES_COLLECT(constructor), tag
            assert ports_utils.collect_type_hints(constructor) is kept, "asked once per class"
    assert ports_utils.collect_type_hints is PY_TREES_COLLECT


def test_the_shipped_trees_attributes_convert_as_py_trees_converts_them() -> None:
    registry = node_registry()
    nodes = [element for element in ElementTree.parse(DEFAULT_TREE).iter()
             if element.tag in registry and element.attrib]
    assert len(nodes) > 50
    plain = [ports_utils.apply_type_hints(registry[node.tag], dict(node.attrib))
             for node in nodes]
    with hints_per_class():
        kept = [ports_utils.apply_type_hints(registry[node.tag], dict(node.attrib))
                for node in nodes]
    assert kept == plain


def test_a_callable_that_cannot_be_a_key_gets_its_hints_each_time() -> None:
    class Unhashable:
        __hash__ = None  # type: ignore[assignment]

        def __call__(self, *, seconds: float) -> None:
            del seconds

    with hints_per_class():
        assert ports_utils.collect_type_hints(Unhashable()) == PY_TREES_COLLECT(Unhashable())


def test_py_trees_function_is_back_after_a_parse_that_fails(tmp_path: Path) -> None:
    broken = tmp_path / "broken.xml"
    broken.write_text("<root main_tree_to_execute='M'><BehaviorTree ID='M'>"
                      "<SimWait name='W' seconds='soon'/></BehaviorTree></root>")
    with pytest.raises(MissionTreeError):
        load_mission_tree(broken)
    assert ports_utils.collect_type_hints is PY_TREES_COLLECT
    load_mission_tree()
    assert ports_utils.collect_type_hints is PY_TREES_COLLECT


def test_a_parse_within_a_parse_leaves_the_outer_one_in_charge() -> None:
    seen: list[Any] = []
    with hints_per_class():
        outer = ports_utils.collect_type_hints
        with hints_per_class():
            seen.append(ports_utils.collect_type_hints)
        seen.append(ports_utils.collect_type_hints)
    assert seen == [outer, outer]
    assert ports_utils.collect_type_hints is PY_TREES_COLLECT
