"""The lockstep pipeline on a live graph: what arrives early for the next period waits for it.

A fake simulator in the test's process announces periods and publishes one topic; the
executive's node joins its lockstep. A message of period 2 that has reached the node before
the tick of period 1 must not be seen by that tick, and must be seen by the tick of period 2.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from servicesim_competition.msg import LockstepDone, LockstepPeriod
from servicesim_competition.srv import LockstepJoin
from std_msgs.msg import String

from bt_servicesim.ros.lockstep import (
    DONE_TOPIC,
    JOIN_SERVICE,
    PERIOD_TOPIC,
    PROTOCOL_QOS,
    LockstepClient,
)
from bt_servicesim.ros.node import ExecutiveNode

TOPIC = "/servicebot/rfid"
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def spin_until(executor: SingleThreadedExecutor, done: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + 20.0
    while not done():
        assert time.monotonic() < deadline, f"no {what} within 20 s"
        executor.spin_once(timeout_sec=0.05)


def announcement(period: int, messages: int) -> LockstepPeriod:
    message = LockstepPeriod(period=period, topics=[TOPIC], messages=[messages])
    message.sim_time.nanosec = period * 100_000_000
    return message


def test_a_message_of_the_next_period_arriving_early_is_not_seen_by_this_periods_tick(
        ros_context: Any) -> None:
    simulator = Node("fake_simulator", context=ros_context)
    node = ExecutiveNode("pipeline_client", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(simulator)
    executor.add_node(node)
    seen: list[str] = []
    seen_at_done: dict[int, list[str]] = {}

    def on_done(done: LockstepDone) -> None:
        seen_at_done.setdefault(int(done.period), list(seen))

    def on_join(_request: Any, response: Any) -> Any:
        response.client, response.joined_at = 7, announcement(0, 0)
        return response

    try:
        writer = simulator.create_publisher(String, TOPIC, RELIABLE)
        announcer = simulator.create_publisher(LockstepPeriod, PERIOD_TOPIC, PROTOCOL_QOS)
        simulator.create_subscription(LockstepDone, DONE_TOPIC, on_done, PROTOCOL_QOS)
        simulator.create_service(LockstepJoin, JOIN_SERVICE, on_join)
        node.create_subscription(String, TOPIC, lambda m: seen.append(m.data), RELIABLE)
        client = LockstepClient(node, name="pipeline")
        spin_until(executor, lambda: writer.get_subscription_count() > 0
                   and announcer.get_subscription_count() > 0, "matching")
        assert client.join(executor, wait_s=10.0)
        assert client.traffic.holding
        writer.publish(String(data="period 1"))
        writer.publish(String(data="period 2, early"))
        spin_until(executor, lambda: sum(client.traffic.received.values()) == 2, "messages")
        announcer.publish(announcement(1, 1))
        spin_until(executor, lambda: 1 in seen_at_done, "done 1")
        assert seen_at_done[1] == ["period 1"]
        announcer.publish(announcement(2, 2))
        spin_until(executor, lambda: 2 in seen_at_done, "done 2")
        assert seen_at_done[2] == ["period 1", "period 2, early"]
        assert client.periods == 2
    finally:
        executor.shutdown()
        node.destroy_node()
        simulator.destroy_node()
