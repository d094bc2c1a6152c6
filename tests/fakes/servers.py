"""What every fake server shares: its node and the :class:`EventLog` of what it saw
(:class:`FakeServer`), and :class:`ServerThread`, which spins fakes in a thread of their own as a
real server runs."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node


@dataclass
class Event:
    """Something a fake server saw, at the sim time the test had published last."""

    what: str
    sim_time: float
    detail: Any = None


@dataclass
class EventLog:
    """What the fake servers saw, in order; the test keeps ``sim_time`` up to date."""

    events: list[Event] = field(default_factory=list)
    sim_time: float = 0.0

    def add(self, what: str, detail: Any = None) -> None:
        self.events.append(Event(what, self.sim_time, detail))

    def named(self, what: str) -> list[Event]:
        return [event for event in self.events if event.what == what]


class FakeServer:
    """A fake's own node and the log it writes; spun by a graph (:meth:`ExecutiveGraph.serve`),
    by a :class:`ServerThread`, or not at all (a server that never answers)."""

    def __init__(self, context: object, node_name: str, log: EventLog | None = None) -> None:
        self.node = Node(node_name, context=context)
        self.log = log if log is not None else EventLog()
        self.stopping = False



class ServerThread:
    """Fake servers spun by a multi-threaded executor in a thread of their own, as a simulator
    serves: requests are answered whether or not the test is spinning."""

    def __init__(self, context: object, *servers: FakeServer, threads: int = 4) -> None:
        self.servers = servers
        self.executor = MultiThreadedExecutor(num_threads=threads, context=context)
        for server in servers:
            self.executor.add_node(server.node)
        self._turn = threading.Lock()
        """Held while the executor takes its next turn (builds its wait set and hands out
        what is ready): an entity destroyed meanwhile is one the wait set may still use."""
        self._stopped = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while not self._stopped.is_set():
            with self._turn:
                self.executor.spin_once(timeout_sec=0.05)

    def between_turns(self, change: Callable[[], None]) -> None:
        """``change`` the servers (destroy one) while the executor is between two turns."""
        with self._turn:
            change()

    def shutdown(self) -> None:
        for server in self.servers:
            server.stopping = True
        self._stopped.set()
        self.thread.join(timeout=5.0)
        self.executor.shutdown()
        for server in self.servers:
            server.node.destroy_node()
