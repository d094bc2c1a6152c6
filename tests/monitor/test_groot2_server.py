"""The Groot2 server on a scripted tree: the tree with uids, statuses after each tick, the
blackboard, a port in use, and a tick that never waits for the server."""

from __future__ import annotations

import struct
import threading
import time
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator

import msgpack
import py_trees
import pytest
import zmq
from py_trees.common import Status

from bt_servicesim.monitor import groot2_server
from bt_servicesim.monitor.groot2_server import Groot2Server, MonitorBindError
from bt_servicesim.monitor.groot2_tree import STATUS_CODES
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.tree.shape import short_label, walk
from tests.monitor.groot2_client import ask
from tests.monitor.scripted_tree import scripted_tree


@pytest.fixture
def server() -> Iterator[Groot2Server]:
    with Groot2Server(port=0) as serving:
        yield serving


def test_the_tree_is_served_with_uids_in_depth_first_order(server: Groot2Server) -> None:
    tree = scripted_tree()
    server.watch(tree)
    _, xml = ask(server.port, "T")
    main = ElementTree.fromstring(xml).find("BehaviorTree")
    assert main is not None and main.get("ID") == "Root"
    nodes = list(main.iter())[1:]
    assert [node.get("_uid") for node in nodes] == [str(uid) for uid in range(1, 11)]
    assert [node.get("name") for node in nodes] == [short_label(b.name) for b in walk(tree.root)]
    assert [node.tag for node in nodes[:3]] == ["Sequence", "Success", "ReactiveFallback"]
    model = {node.get("ID"): node.tag for node in ElementTree.fromstring(xml).find(
        "TreeNodesModel")}
    assert model == {"Success": "Action", "Failure": "Action", "StatusQueue": "Action",
                     "Inverter": "Decorator"}


def served_statuses(port: int) -> list[tuple[int, int]]:
    return list(struct.iter_unpack("<HB", ask(port, "S")[1]))


def test_statuses_are_the_trees_as_of_the_last_tick(server: Groot2Server) -> None:
    tree = scripted_tree()
    server.watch(tree)
    assert {code for _, code in served_statuses(server.port)} == {0}
    for _ in range(2):
        tree.tick()
        expected = [(uid, STATUS_CODES[b.status]) for uid, b in enumerate(walk(tree.root), 1)]
        assert served_statuses(server.port) == expected
    assert dict(served_statuses(server.port))[8] == 1  # Work RUNNING


def test_the_blackboard_is_served_by_the_trees_name_and_as_root(server: Groot2Server) -> None:
    writer = py_trees.blackboard.Client(name="writer")
    writer.register_key("robot_pose", access=py_trees.common.Access.WRITE)
    writer.robot_pose = Pose2D(1.0, 2.0, 0.5)
    tree = scripted_tree()
    server.watch(tree)
    tree.tick()
    payload = msgpack.unpackb(ask(server.port, "B", b"Root;ROOT")[1])
    pose = {"__type": "Pose2D", "x": 1.0, "y": 2.0, "yaw": 0.5}
    assert payload == {"Root": {"robot_pose": pose}, "ROOT": {"robot_pose": pose}}


def test_before_a_tree_is_watched_requests_get_the_error_answer(server: Groot2Server) -> None:
    assert ask(server.port, "T") == [b"error", b"no tree is being monitored yet"]


def test_a_port_in_use_is_one_line_naming_the_address(server: Groot2Server) -> None:
    with pytest.raises(MonitorBindError) as raised:
        Groot2Server(port=server.port)
    message = str(raised.value)
    assert f"127.0.0.1:{server.port}" in message and "\n" not in message


def test_closing_stops_the_thread_and_frees_the_port() -> None:
    first = Groot2Server(port=0)
    first.close()
    first.close()  # idempotent
    assert not first._thread.is_alive()
    with Groot2Server(port=first.port) as second:
        assert second.port == first.port


def test_a_server_stalled_mid_request_never_blocks_the_tick(
        server: Groot2Server, monkeypatch: pytest.MonkeyPatch) -> None:
    """The server thread is stuck answering; the tree keeps ticking and publishing."""
    entered, release = threading.Event(), threading.Event()
    real_answer = groot2_server.answer

    def stalled(*args: object, **kwargs: object) -> list[bytes]:
        entered.set()
        release.wait(30)
        return real_answer(*args, **kwargs)

    monkeypatch.setattr(groot2_server, "answer", stalled)
    tree = scripted_tree()
    server.watch(tree)
    replies: list[list[bytes]] = []
    client = threading.Thread(target=lambda: replies.append(ask(server.port, "S")))
    client.start()
    assert entered.wait(10), "the request never reached the server"
    for _ in range(5):
        tree.tick()
    assert tree.root.status == Status.SUCCESS and tree.count == 5
    assert server._latest is not None and server._latest.statuses[0] == Status.SUCCESS
    release.set()
    client.join(10)
    assert replies and struct.unpack_from("<HB", replies[0][1]) == (1, 0)  # as when asked
    assert served_statuses(server.port)[0] == (1, 2)  # the next request: as of the last tick


def test_requests_while_ticking_never_see_a_torn_status_buffer(server: Groot2Server) -> None:
    tree = scripted_tree()
    server.watch(tree)
    stop = threading.Event()

    def tick() -> None:
        while not stop.is_set():
            tree.tick()

    ticking = threading.Thread(target=tick)
    ticking.start()
    try:
        for _ in range(50):
            assert [uid for uid, _ in served_statuses(server.port)] == list(range(1, 11))
    finally:
        stop.set()
        ticking.join()


def test_a_client_that_leaves_mid_request_does_not_stop_the_server(server: Groot2Server) -> None:
    server.watch(scripted_tree())
    context = zmq.Context.instance()
    leaver = context.socket(zmq.REQ)
    leaver.setsockopt(zmq.LINGER, 0)
    leaver.connect(f"tcp://127.0.0.1:{server.port}")
    leaver.send_multipart([b"\x02T\x00\x00\x00\x00"])
    leaver.close()
    time.sleep(0.2)
    assert ask(server.port, "S")[0][:2] == b"\x02S"
