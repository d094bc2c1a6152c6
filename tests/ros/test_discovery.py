"""The discovery probe: once a /clock reader made last has a message from the backend, the
backend's writers have matched every reader made before it; without a clock it gives up in
bounded time, and leaves no reader behind either way."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Int32

from bt_servicesim.ros.discovery import CLOCK_TOPIC, await_backend_discovery

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
TOPICS = 12


class Backend:
    """A participant of its own (a second context) that repeats /clock every 50 ms, as the
    simulator does while it holds for a client, and has writers on ``/probe_test/<n>``."""

    def __init__(self, *, clock: bool) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("probe_backend", context=self.context)
        self.writers = [self.node.create_publisher(Int32, f"/probe_test/t{n}", RELIABLE)
                        for n in range(TOPICS)]
        if clock:
            publisher = self.node.create_publisher(Clock, CLOCK_TOPIC, 10)
            self.node.create_timer(0.05, lambda: publisher.publish(Clock()))
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def __enter__(self) -> Backend:
        return self

    def __exit__(self, *_: object) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()
        self.thread.join(timeout=5.0)


@pytest.fixture
def client(ros_context: Context) -> Iterator[tuple[Node, SingleThreadedExecutor]]:
    node = Node("probe_client", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()


def test_after_the_probe_the_backend_has_matched_every_earlier_reader(
        client: tuple[Node, SingleThreadedExecutor]) -> None:
    node, executor = client
    with Backend(clock=True) as backend:
        for n in range(TOPICS):  # one reader at a time, each proved by a probe of its own
            node.create_subscription(Int32, f"/probe_test/t{n}", lambda _m: None, RELIABLE)
            assert await_backend_discovery(node, executor, limit_s=10.0)
            matched = [writer.get_subscription_count() for writer in backend.writers[:n + 1]]
            assert matched == [1] * (n + 1), f"after reader {n}: {matched}"


def test_without_a_clock_it_gives_up_within_its_limit_and_leaves_no_reader(
        client: tuple[Node, SingleThreadedExecutor]) -> None:
    node, executor = client
    with Backend(clock=False):
        started = time.monotonic()
        assert not await_backend_discovery(node, executor, limit_s=0.4)
        assert 0.4 <= time.monotonic() - started < 3.0
        assert node.count_subscribers(CLOCK_TOPIC) == 0
        assert [s.topic_name for s in node.subscriptions] == []
