"""Graphs a test spins from its own thread: :class:`ExecutiveGraph` (a behaviour's node, with
``tick_until_done``), :class:`SimTimeGraph` (a node on sim time and a simulator node publishing
``/clock``) and :class:`SensorWorld` (adds the RFID, odometry and transform publishers)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, TypeVar

import py_trees
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from servicesim_competition.msg import ActorNames
from tf2_msgs.msg import TFMessage

from tests.fakes.servers import FakeServer
from tests.fakes.spinning import clock_message, spin_until

Status = py_trees.common.Status

T = TypeVar("T", bound="FakeServer")


class ExecutiveGraph:
    """A behaviour's node and the executor the test spins between ticks; fakes join it with
    :meth:`serve` and are then answered from the test's thread."""

    def __init__(self, context: object, node_name: str = "executive") -> None:
        self.node = Node(node_name, context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.served: list[FakeServer] = []

    def serve(self, server: T) -> T:
        self.executor.add_node(server.node)
        self.served.append(server)
        return server

    def spin_until(self, done: Callable[[], bool], what: str = "the condition",
                   limit_s: float = 10.0) -> None:
        spin_until(self.executor, done, what, limit_s=limit_s)

    def tick_until(self, behaviour: py_trees.behaviour.Behaviour, done: Callable[[], bool],
                   limit_s: float = 10.0) -> None:
        """Tick, spinning between ticks, until ``done()`` after a tick."""
        deadline = time.monotonic() + limit_s
        while True:
            behaviour.tick_once()
            if done():
                return
            assert time.monotonic() < deadline, f"still RUNNING: {behaviour.feedback_message}"
            self.executor.spin_once(timeout_sec=0.01)

    def tick_until_done(self, behaviour: py_trees.behaviour.Behaviour,
                        limit_s: float = 10.0) -> Status:
        self.tick_until(behaviour, lambda: behaviour.status != Status.RUNNING, limit_s)
        return behaviour.status

    def shutdown(self) -> None:
        self.executor.shutdown()
        for node in [self.node, *(server.node for server in self.served)]:
            node.destroy_node()


class SimTimeGraph:
    """A node on sim time and a simulator node publishing ``/clock``, on one executor the test
    spins from its own thread."""

    def __init__(self, context: object, node_name: str = "executive",
                 simulator_name: str = "simulator") -> None:
        self.node = Node(node_name, context=context, parameter_overrides=[
            Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        self.simulator = Node(simulator_name, context=context)
        self.clock = self.simulator.create_publisher(Clock, "/clock", 10)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.simulator)

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds / 1e9

    def spin_until(self, done: Callable[[], bool], what: str = "the condition", *,
                   before: Callable[[], Any] = lambda: None, limit_s: float = 20.0) -> None:
        spin_until(self.executor, done, what, before=before, limit_s=limit_s)

    def jump_to(self, seconds: float, limit_s: float = 20.0) -> None:
        """Publish ``/clock`` = ``seconds`` until the node's clock reads exactly that."""
        message = clock_message(seconds)
        target = round(seconds * 1e9)
        self.spin_until(lambda: self.node.get_clock().now().nanoseconds == target,
                        f"sim time {seconds}", before=lambda: self.clock.publish(message),
                        limit_s=limit_s)

    def shutdown(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.simulator.destroy_node()


class SensorWorld(SimTimeGraph):
    """A :class:`SimTimeGraph` whose simulator also publishes the robot's RFID, odometry and
    transforms."""

    def __init__(self, context: object) -> None:
        super().__init__(context)
        self.rfid = self.simulator.create_publisher(ActorNames, "/servicebot/rfid", 10)
        self.odom = self.simulator.create_publisher(Odometry, "/servicebot/odom", 10)
        self.tf = self.simulator.create_publisher(TFMessage, "/tf", 100)
