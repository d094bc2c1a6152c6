"""A Groot2 monitor server for a py_trees tree: a ZMQ REP socket served on a thread of its own.

Groot2, ``btview`` and anything else written for BehaviorTree.CPP's ``Groot2Publisher`` connect
to it and poll the tree, its statuses and its blackboard (:mod:`.groot2_protocol` decides every
byte of the answers).

It never slows the tick. After each tick the tree's post-tick handler publishes a
:class:`Snapshot` -- the behaviours' statuses and a shallow copy of the blackboard's entries,
O(nodes) references copied and nothing encoded -- by replacing one attribute, which is atomic
in Python: no lock is shared between the tick and the server, so a server that is slow, stalled
or busy encoding never makes the tick wait. The server thread encodes whichever snapshot is the
latest when a request arrives. A blackboard value the tick mutates in place while the server
walks it is read as it happens to be; an encoding that fails gets the protocol's error answer.

The server binds when it is made, so a port in use is an error before anything else starts,
and answers from then on (an error answer until a tree is watched). :meth:`Groot2Server.close`
stops the thread within one poll period (0.1 s) and releases the port; the thread is a daemon,
so even a run that never closes it does not hang at exit.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import py_trees
import zmq
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from bt_servicesim.monitor.groot2_protocol import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    Served,
    answer,
    error_reply,
    new_tree_id,
)
from bt_servicesim.monitor.groot2_tree import MonitoredTree, status_codes

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "Groot2Server", "MonitorBindError", "Snapshot"]

POLL_PERIOD_MS = 100
"""How long the server waits for a request before it looks whether it should stop."""
SEND_TIMEOUT_MS = 1000
"""A reply nobody takes is dropped after this long (as BehaviorTree.CPP's publisher does)."""
ROOT_BLACKBOARD = "ROOT"
"""BehaviorTree.CPP's name for the root blackboard; py_trees has one blackboard, the root."""


class MonitorBindError(OSError):
    """The monitor cannot listen where it was asked; the message is one line."""


@dataclass(frozen=True)
class Snapshot:
    """The tree after one tick: statuses in uid order and the blackboard's entries."""

    statuses: tuple[Status, ...]
    blackboard: Mapping[str, Any]


class Groot2Server:
    """Serves the latest :class:`Snapshot` of a watched tree to Groot2 clients.

    Args:
        host: the address to listen on (an IPv4 address; ``0.0.0.0`` for every interface)
        port: the REP socket's port (``0`` for any free one, see :attr:`port`)
    """

    def __init__(self, *, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> None:
        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.REP)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.SNDTIMEO, SEND_TIMEOUT_MS)
        try:
            if port == 0:
                self.port = self._socket.bind_to_random_port(f"tcp://{host}")
            else:
                self._socket.bind(f"tcp://{host}:{port}")
                self.port = port
        except zmq.ZMQError as error:
            self._socket.close()
            self._context.term()
            raise MonitorBindError(
                f"cannot serve Groot2 on {host}:{port}: {error.strerror}") from error
        self.host = host
        self.requests = 0
        self._tree_id = new_tree_id()
        self._tree: MonitoredTree | None = None
        self._latest: Snapshot | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="groot2-server", daemon=True)
        self._thread.start()

    def watch(self, tree: py_trees.trees.BehaviourTree, *, tree_id: str | None = None) -> None:
        """Serve ``tree`` from now on, its statuses as of each tick's end."""
        self._tree = MonitoredTree.of(tree.root, tree_id=tree_id)
        self.publish(tree)
        tree.add_post_tick_handler(self.publish)

    def publish(self, tree: py_trees.trees.BehaviourTree | None = None) -> None:
        """Take a snapshot of the watched tree (the post-tick handler; ``tree`` is unused)."""
        if self._tree is not None:
            self._latest = Snapshot(statuses=self._tree.statuses(),
                                    blackboard=dict(Blackboard.storage))

    def close(self) -> None:
        """Stop serving and release the port; idempotent."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join()
        self._socket.close()
        self._context.term()

    def __enter__(self) -> Groot2Server:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _serve(self) -> None:
        while not self._stop.is_set():
            if not self._socket.poll(POLL_PERIOD_MS):
                continue
            frames = self._socket.recv_multipart()
            self.requests += 1
            try:
                reply = self.reply_to(frames)
            except Exception as error:  # a value that cannot be encoded: the client is told
                reply = error_reply(f"{type(error).__name__}: {error}")
            try:
                self._socket.send_multipart(reply)
            except zmq.Again:  # the client left; the REP socket is ready for the next
                continue

    def reply_to(self, frames: list[bytes]) -> list[bytes]:
        """The answer to one request, from the latest snapshot (the server thread's work)."""
        tree, snapshot = self._tree, self._latest
        if tree is None or snapshot is None:
            return error_reply("no tree is being monitored yet")
        return answer(frames, Served(
            tree_id=self._tree_id, tree_xml=tree.xml, statuses=status_codes(snapshot.statuses),
            blackboards=lambda: _blackboards(tree.tree_id, snapshot.blackboard)))


def _blackboards(tree_id: str, entries: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The one py_trees blackboard under the tree's name and ``ROOT``, keys without their
    leading ``/``."""
    named = {key.removeprefix("/"): value for key, value in entries.items()}
    return {tree_id: named, ROOT_BLACKBOARD: named}
