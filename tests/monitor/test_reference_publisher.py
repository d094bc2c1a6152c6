"""Our server against the reference: BehaviorTree.CPP's own ``Groot2Publisher`` (shipped by
the ``behaviortreepy`` wheel) serving a tree of the same shape. The same requests go to both and
the replies must have the same framing and layout, byte for byte where the protocol fixes it.

Where the two differ by design it is said here: BehaviorTree.CPP resets a finished tree's nodes
to IDLE and reports "idle, was s" (10 + s) where py_trees keeps s; its model lists all of its
built-in nodes; it packs a float that fits in 32 bits as one (both decode to the same value)."""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator

import behaviortreepy as btcpp
import msgpack
import py_trees
import pytest
from py_trees.common import Status

from bt_servicesim.monitor.groot2_protocol import REPLY_HEADER_SIZE, RequestHeader
from bt_servicesim.monitor.groot2_server import Groot2Server
from tests.monitor.groot2_client import ask, exchange, free_port

REFERENCE_XML = """<root BTCPP_format="4" main_tree_to_execute="Main"><BehaviorTree ID="Main">
  <Sequence name="Root">
    <Leaf name="a"/>
    <Fallback name="F"><Check name="c"/><Leaf name="b"/></Fallback>
  </Sequence>
</BehaviorTree></root>"""
BLACKBOARD = {"count": 3, "guest": "human_1", "distance": 1.5}


class Leaf(py_trees.behaviour.Behaviour):
    """Succeeds, like the reference's ``Leaf``."""

    def update(self) -> Status:
        return Status.SUCCESS


class Check(py_trees.behaviour.Behaviour):
    """Fails, like the reference's ``Check``."""

    def update(self) -> Status:
        return Status.FAILURE


@pytest.fixture
def reference() -> Iterator[int]:
    """The reference publisher's port, its tree ticked once and its blackboard filled."""
    if not btcpp.GROOT2_AVAILABLE:
        pytest.fail("behaviortreepy was built without Groot2 support")
    factory = btcpp.BehaviorTreeFactory()
    factory.register_simple_action("Leaf", lambda node: btcpp.NodeStatus.SUCCESS)
    factory.register_simple_action("Check", lambda node: btcpp.NodeStatus.FAILURE)
    tree = factory.create_tree_from_text(REFERENCE_XML)
    blackboard = tree.root_blackboard()
    blackboard.set_int("count", BLACKBOARD["count"])
    blackboard.set_string("guest", BLACKBOARD["guest"])
    blackboard.set_double("distance", BLACKBOARD["distance"])
    port = free_port(consecutive=2)
    publisher = btcpp.Groot2Publisher(tree, port)
    tree.tick_once()
    yield port
    del publisher


@pytest.fixture
def ours() -> Iterator[int]:
    """Our server's port, on a py_trees tree of the reference's shape, ticked once."""
    root = py_trees.composites.Sequence(name="Root", memory=True, children=[
        Leaf(name="a"),
        py_trees.composites.Selector(name="F", memory=True,
                                     children=[Check(name="c"), Leaf(name="b")]),
    ])
    tree = py_trees.trees.BehaviourTree(root)
    for key, value in BLACKBOARD.items():
        py_trees.blackboard.Blackboard.set(f"/{key}", value)
    with Groot2Server(port=0) as server:
        server.watch(tree, tree_id="Main")
        tree.tick()
        yield server.port


def both(reference: int, ours: int, kind: str, *extra: bytes) -> tuple[list[bytes], ...]:
    return ask(reference, kind, *extra), ask(ours, kind, *extra)


def assert_same_reply_header(theirs: bytes, mine: bytes, kind: str) -> None:
    assert len(theirs) == len(mine) == REPLY_HEADER_SIZE
    assert RequestHeader.from_bytes(theirs[:6]).request_type == ord(kind)
    assert theirs[:2] == mine[:2] == bytes([2, ord(kind)])


def structure(element: ElementTree.Element) -> tuple[object, ...]:
    return (element.tag, element.get("name"), element.get("_uid"),
            tuple(structure(child) for child in element))


def test_the_full_tree_has_the_same_frames_header_and_xml_structure(
        reference: int, ours: int) -> None:
    theirs, mine = both(reference, ours, "T")
    assert len(theirs) == len(mine) == 2
    assert_same_reply_header(theirs[0], mine[0], "T")
    their_root, my_root = ElementTree.fromstring(theirs[1]), ElementTree.fromstring(mine[1])
    assert my_root.attrib == their_root.attrib == {"BTCPP_format": "4"}
    their_tree, my_tree = their_root.find("BehaviorTree"), my_root.find("BehaviorTree")
    assert my_tree.attrib == their_tree.attrib == {"ID": "Main", "_fullpath": ""}
    assert [structure(node) for node in my_tree] == [structure(node) for node in their_tree]
    their_model = {node.get("ID"): node.tag for node in their_root.find("TreeNodesModel")}
    for node in my_root.find("TreeNodesModel"):
        assert their_model[node.get("ID")] == node.tag


def test_the_status_buffer_has_the_same_layout_and_statuses(reference: int, ours: int) -> None:
    theirs, mine = both(reference, ours, "S")
    assert len(theirs) == len(mine) == 2
    assert_same_reply_header(theirs[0], mine[0], "S")
    assert len(theirs[1]) == len(mine[1]) == 3 * 5
    their_codes = list(struct.iter_unpack("<HB", theirs[1]))
    my_codes = list(struct.iter_unpack("<HB", mine[1]))
    # BehaviorTree.CPP has reset its finished tree to "idle, was s" (10 + s)
    assert my_codes == [(uid, code - 10 if code >= 10 else code) for uid, code in their_codes]
    assert my_codes == [(1, 2), (2, 2), (3, 2), (4, 3), (5, 2)]


def test_the_blackboard_is_the_same_messagepack_map(reference: int, ours: int) -> None:
    theirs, mine = both(reference, ours, "B", b"Main")
    assert len(theirs) == len(mine) == 2
    assert_same_reply_header(theirs[0], mine[0], "B")
    assert mine[1][:1] == theirs[1][:1] == b"\x81"  # a map of one blackboard
    assert msgpack.unpackb(mine[1]) == msgpack.unpackb(theirs[1]) == {"Main": BLACKBOARD}


@pytest.mark.parametrize(("frames"), [
    [b"\x02?\x00\x00\x00\x00"],  # no such request type
    [b"\x02S"],  # a header too short
    [b"\x02B\x00\x00\x00\x00"],  # a blackboard request without names
])
def test_bad_requests_get_the_same_error_answer(reference: int, ours: int,
                                                frames: list[bytes]) -> None:
    theirs = exchange(reference, frames)
    mine = exchange(ours, frames)
    assert mine == theirs
    assert mine[0] == b"error"

