"""Shared subscriptions: one per topic and node while the QoS allows (the same reliability, at
least the durability and depth), every waiting message to every reader in one wake-up, bytes or
decoded, and gone with the last reader."""

from __future__ import annotations

from collections.abc import Iterator
from typing import TypeVar

import pytest
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.serialization import deserialize_message
from std_msgs.msg import Int32

from bt_servicesim.ros.node import ExecutiveNode
from bt_servicesim.ros.shared_subscription import SharedSubscription, shared_subscription
from tests.fakes.spinning import spin_until, wait_for_subscription

N = TypeVar("N", bound=Node)
RELIABLE_50 = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def reader_and_writer(reader: N, ros_context: Context) -> Iterator[
        tuple[N, Node, SingleThreadedExecutor]]:
    """``reader`` spun by an executor, and a writer node beside it; both destroyed after."""
    writer = Node("shared_writer", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(reader)
    yield reader, writer, executor
    executor.shutdown()
    reader.destroy_node()
    writer.destroy_node()


@pytest.fixture
def nodes(ros_context: Context) -> Iterator[tuple[Node, Node, SingleThreadedExecutor]]:
    yield from reader_and_writer(Node("shared_reader", context=ros_context), ros_context)


def subscription_count(node: Node) -> int:
    return len(list(node.subscriptions))


def burst_then_one_wake_up(writer: Node, executor: SingleThreadedExecutor, *,
                           count: int) -> None:
    """Publish 0..count-1 on /shared/a, let them all arrive, then spin the reader once."""
    publisher = writer.create_publisher(Int32, "/shared/a", RELIABLE_50)
    wait_for_subscription(publisher)
    for value in range(count):
        publisher.publish(Int32(data=value))
    assert publisher.wait_for_all_acked(Duration(seconds=30)), "the reader's queue took them all"
    executor.spin_once(timeout_sec=5.0)


def test_readers_asking_no_more_than_the_first_share_its_subscription(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, _, _ = nodes
    shared_subscription(node, Int32, "/shared/a", print, RELIABLE_50, raw=True)
    shared_subscription(node, Int32, "/shared/a", print, 10)
    assert subscription_count(node) == 1
    shared_subscription(node, Int32, "/shared/a", print, qos_profile_sensor_data)  # best effort
    shared_subscription(node, Int32, "/shared/a", print, LATCHED)  # asks for transient local
    shared_subscription(node, Int32, "/shared/a", print, 100)  # asks for a deeper history
    shared_subscription(node, Int32, "/shared/b", print, 10)  # another topic
    assert subscription_count(node) == 5


BEST_EFFORT_5 = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
BEST_EFFORT_LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
KEEP_ALL = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                      reliability=ReliabilityPolicy.RELIABLE)


@pytest.mark.parametrize(("have", "want", "covered"), [
    (RELIABLE_50, BEST_EFFORT_5, False),  # a reliable reader hears no best-effort publisher
    (BEST_EFFORT_5, RELIABLE_50, False),  # a best-effort one would drop what was asked for
    (BEST_EFFORT_5, qos_profile_sensor_data, True),
    (RELIABLE_50, QoSProfile(depth=10), True),  # reliable by default, and not as deep
    (RELIABLE_50, QoSProfile(depth=100), False),  # deeper
    (KEEP_ALL, RELIABLE_50, True),
    (RELIABLE_50, KEEP_ALL, False),
    (LATCHED, QoSProfile(depth=1), True),  # transient local covers volatile
    (QoSProfile(depth=1), LATCHED, False),
    (BEST_EFFORT_LATCHED, BEST_EFFORT_5, False),  # transient local, but not as deep
    (BEST_EFFORT_LATCHED, QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
     True),
])
def test_a_subscription_covers_a_request_of_the_same_reliability_asking_no_more(
        nodes: tuple[Node, Node, SingleThreadedExecutor], have: QoSProfile, want: QoSProfile,
        covered: bool) -> None:
    node, _, _ = nodes
    assert SharedSubscription(node, Int32, "/shared/a", have).covers(want) is covered


@pytest.fixture
def executive(ros_context: Context) -> Iterator[tuple[ExecutiveNode, Node,
                                                      SingleThreadedExecutor]]:
    yield from reader_and_writer(ExecutiveNode("shared_executive", context=ros_context),
                                 ros_context)


def test_a_best_effort_reader_after_a_reliable_one_hears_a_best_effort_publisher(
        executive: tuple[ExecutiveNode, Node, SingleThreadedExecutor]) -> None:
    """The run's recorder reads odometry and RFID reliably before the tree's sensor readers
    ask for best effort: on a backend publishing best effort, the tree must still hear."""
    node, writer, executor = executive
    recorded: list[Int32] = []
    sensed: list[Int32] = []
    shared_subscription(node, Int32, "/shared/sensor", recorded.append, RELIABLE_50)
    shared_subscription(node, Int32, "/shared/sensor", sensed.append, qos_profile_sensor_data)
    publisher = writer.create_publisher(Int32, "/shared/sensor", qos_profile_sensor_data)
    spin_until(executor, lambda: bool(sensed), "the best-effort reader to hear",
               before=lambda: publisher.publish(Int32(data=7)), limit_s=10.0, step_s=0.05)
    assert sensed[0].data == 7 and recorded == []  # the reliable reader matches no such writer


def test_in_lockstep_a_best_effort_reader_shares_a_reliable_subscription(
        executive: tuple[ExecutiveNode, Node, SingleThreadedExecutor]) -> None:
    """In lockstep every subscription of the node is made reliable, so the tree's sensor
    readers still ride on the recorder's subscription: one per topic, as before."""
    node, _, _ = executive
    node.reliable_subscriptions = True
    before = subscription_count(node)  # rclpy's own /clock reader
    shared_subscription(node, Int32, "/shared/sensor", print, RELIABLE_50, raw=True)
    shared_subscription(node, Int32, "/shared/sensor", print, qos_profile_sensor_data)
    assert subscription_count(node) == before + 1


def test_a_best_effort_subscription_is_not_shared_with_a_reader_wanting_reliable(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, _, _ = nodes
    shared_subscription(node, Int32, "/shared/a", print, qos_profile_sensor_data)
    shared_subscription(node, Int32, "/shared/a", print, 5)  # reliable, depth 5
    assert subscription_count(node) == 2


def test_one_wake_up_hands_every_waiting_message_to_every_reader(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, writer, executor = nodes
    raw: list[bytes] = []
    decoded: list[Int32] = []
    also_decoded: list[Int32] = []
    shared_subscription(node, Int32, "/shared/a", raw.append, RELIABLE_50, raw=True)
    shared_subscription(node, Int32, "/shared/a", decoded.append, 10)
    shared_subscription(node, Int32, "/shared/a", also_decoded.append, 10)
    burst_then_one_wake_up(writer, executor, count=4)
    assert [deserialize_message(data, Int32).data for data in raw] == [0, 1, 2, 3]
    assert [message.data for message in decoded] == [0, 1, 2, 3]
    assert all(a is b for a, b in zip(decoded, also_decoded, strict=True))  # decoded once


def test_the_subscription_goes_with_its_last_reader(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, _, _ = nodes
    first = shared_subscription(node, Int32, "/shared/a", print, 10)
    second = shared_subscription(node, Int32, "/shared/a", print, 10)
    first.cancel()
    assert subscription_count(node) == 1
    second.cancel()
    assert subscription_count(node) == 0
    shared_subscription(node, Int32, "/shared/a", print, 10)  # a new reader: a new one
    assert subscription_count(node) == 1


def test_a_latched_message_reaches_a_reader_that_joins_after_it_arrived(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, writer, executor = nodes
    first: list[bytes] = []
    shared_subscription(node, Int32, "/shared/latched", first.append, LATCHED, raw=True)
    publisher = writer.create_publisher(Int32, "/shared/latched", LATCHED)
    publisher.publish(Int32(data=1))
    publisher.publish(Int32(data=7))
    spin_until(executor, lambda: bool(first), "the latched message", limit_s=10.0, step_s=0.1)
    late: list[Int32] = []
    shared_subscription(node, Int32, "/shared/latched", late.append, LATCHED)
    assert subscription_count(node) == 1
    assert [message.data for message in late] == [7]  # the history DDS keeps: the last one


def test_a_latest_only_reader_gets_the_newest_of_a_burst(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, writer, executor = nodes
    every: list[int] = []
    newest: list[int] = []
    shared_subscription(node, Int32, "/shared/a", lambda m: every.append(m.data), RELIABLE_50)
    shared_subscription(node, Int32, "/shared/a", lambda m: newest.append(m.data), 10,
                        latest_only=True)
    burst_then_one_wake_up(writer, executor, count=4)
    assert every == [0, 1, 2, 3] and newest == [3]


def test_a_volatile_reader_joining_a_latched_subscription_gets_no_old_message(
        nodes: tuple[Node, Node, SingleThreadedExecutor]) -> None:
    node, writer, executor = nodes
    first: list[bytes] = []
    shared_subscription(node, Int32, "/shared/latched", first.append, LATCHED, raw=True)
    writer.create_publisher(Int32, "/shared/latched", LATCHED).publish(Int32(data=7))
    spin_until(executor, lambda: bool(first), "the latched message", limit_s=10.0, step_s=0.1)
    late: list[Int32] = []
    shared_subscription(node, Int32, "/shared/latched", late.append, 1)  # volatile
    assert subscription_count(node) == 1 and late == []
