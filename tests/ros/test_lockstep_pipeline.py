"""The lockstep pipeline on a live graph: what arrives early for the next period waits for it.

A fake simulator in the test's process announces periods and publishes one topic; the
executive's node joins its lockstep. A message of period 2 that has reached the node before
the tick of period 1 must not be seen by that tick, and must be seen by the tick of period 2.
A client the simulator went on without (an announcement further ahead than a simulator waiting
for it could make) hands on what it held and ticks free, with no more done messages.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
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


@dataclass
class FakeSimulator:
    """The simulator's side of the protocol in the test's process, and a joined client."""

    executor: SingleThreadedExecutor
    writer: Any
    announcer: Any
    client: LockstepClient
    seen: list[str] = field(default_factory=list)
    seen_at_done: dict[int, list[str]] = field(default_factory=dict)
    readings_at_done: dict[int, list[tuple[str, int]]] = field(default_factory=dict)

    def on_done(self, done: LockstepDone) -> None:
        self.seen_at_done.setdefault(int(done.period), list(self.seen))
        self.readings_at_done.setdefault(int(done.period), list(zip(
            done.reading_topics, (int(first) for first in done.reading_from), strict=True)))

    def announce(self, period: int, messages: int) -> None:
        self.announcer.publish(announcement(period, messages))

    def spin_until(self, done: Callable[[], bool], what: str) -> None:
        spin_until(self.executor, done, what)


@contextmanager
def joined(ros_context: Any) -> Iterator[FakeSimulator]:
    """A fake simulator publishing one topic, and an executive's node joined to its lockstep."""
    simulator = Node("fake_simulator", context=ros_context)
    node = ExecutiveNode("pipeline_client", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(simulator)
    executor.add_node(node)

    def on_join(_request: Any, response: Any) -> Any:
        response.client, response.joined_at = 7, announcement(0, 0)
        return response

    try:
        writer = simulator.create_publisher(String, TOPIC, RELIABLE)
        announcer = simulator.create_publisher(LockstepPeriod, PERIOD_TOPIC, PROTOCOL_QOS)
        simulator.create_service(LockstepJoin, JOIN_SERVICE, on_join)
        fake = FakeSimulator(executor=executor, writer=writer, announcer=announcer,
                             client=LockstepClient(node, name="pipeline"))
        simulator.create_subscription(LockstepDone, DONE_TOPIC, fake.on_done, PROTOCOL_QOS)
        node.create_subscription(String, TOPIC, lambda m: fake.seen.append(m.data), RELIABLE)
        fake.spin_until(lambda: writer.get_subscription_count() > 0
                        and announcer.get_subscription_count() > 0, "matching")
        assert fake.client.join(executor, wait_s=10.0)
        yield fake
    finally:
        executor.shutdown()
        node.destroy_node()
        simulator.destroy_node()


def test_a_message_of_the_next_period_arriving_early_is_not_seen_by_this_periods_tick(
        ros_context: Any) -> None:
    with joined(ros_context) as fake:
        client = fake.client
        assert client.traffic.holding
        fake.writer.publish(String(data="period 1"))
        fake.writer.publish(String(data="period 2, early"))
        fake.spin_until(lambda: sum(client.traffic.received.values()) == 2, "messages")
        fake.announce(1, 1)
        fake.spin_until(lambda: 1 in fake.seen_at_done, "done 1")
        assert fake.seen_at_done[1] == ["period 1"]
        fake.announce(2, 2)
        fake.spin_until(lambda: 2 in fake.seen_at_done, "done 2")
        assert fake.seen_at_done[2] == ["period 1", "period 2, early"]
        assert client.periods == 2


def test_a_client_the_simulator_went_on_without_hands_on_what_it_held_and_runs_free(
        ros_context: Any) -> None:
    with joined(ros_context) as fake:
        client = fake.client
        ticked_at: list[float] = []
        client.ticker(0.1, lambda: ticked_at.append(
            client.node.get_clock().now().nanoseconds / 1e9))
        fake.writer.publish(String(data="period 1"))
        fake.announce(1, 1)
        fake.spin_until(lambda: 1 in fake.seen_at_done, "done 1")
        # two periods past the last done are what a simulator waiting for it may announce
        fake.writer.publish(String(data="period 2"))
        fake.announce(2, 2)
        fake.announce(3, 2)
        fake.spin_until(lambda: 3 in fake.seen_at_done, "done 3")
        assert client.dropped_at is None and client.periods == 3
        fake.writer.publish(String(data="period 4, held"))
        fake.spin_until(lambda: sum(client.traffic.received.values()) == 3, "message 3")
        assert fake.seen == ["period 1", "period 2"]  # held for period 4's tick
        fake.announce(6, 3)  # three past done 3: the simulator did not wait for done 4
        fake.spin_until(lambda: client.periods == 4, "the tick of period 6")
        assert client.dropped_at is not None and client.dropped_at.period == 6
        assert fake.seen == ["period 1", "period 2", "period 4, held"]
        assert not client.traffic.holding
        fake.writer.publish(String(data="free"))
        fake.spin_until(lambda: fake.seen[-1] == "free", "a message handed on as it came")
        fake.announce(7, 4)
        fake.spin_until(lambda: client.periods == 5, "the tick of period 7")
        assert ticked_at == [0.2, 0.3, 0.6, 0.7]  # the periods in between are skipped
        for _ in range(10):
            fake.executor.spin_once(timeout_sec=0.02)
        assert sorted(fake.seen_at_done) == [0, 1, 2, 3]  # no done once dropped


def test_work_left_for_after_the_done_runs_after_it_goes_out_and_at_once_between_periods(
        ros_context: Any) -> None:
    with joined(ros_context) as fake:
        client = fake.client
        events: list[str] = []
        publish = client._done.publish
        client._done.publish = lambda message: (events.append("done"), publish(message))

        def tick() -> None:
            events.append("tick")
            client.after_done(lambda: events.append("record"))
            client.after_done(lambda: 1 / 0)  # kept as the node's error, not raised

        client.ticker(0.1, tick)
        for period in (1, 2, 3):
            fake.announce(period, 0)
            fake.spin_until(lambda period=period: period in fake.seen_at_done, f"done {period}")
        # the ticker's first call only sets its due time, as a timer's first period does
        assert events == ["done", "tick", "done", "record", "tick", "done", "record"]
        assert "ZeroDivisionError" in (client.node.callback_traceback or "")
        client.after_done(lambda: events.append("between periods"))
        assert events[-1] == "between periods"


CAMERA = "/servicebot/camera_front/image_raw"


def announce_with_camera(fake: FakeSimulator, period: int, pictures: int) -> None:
    message = LockstepPeriod(period=period, topics=[CAMERA, TOPIC], messages=[pictures, 0])
    message.sim_time.nanosec = period * 100_000_000
    fake.announcer.publish(message)


def test_a_subscription_made_after_the_join_is_named_and_counted_from_two_periods_on(
        ros_context: Any) -> None:
    """The camera, subscribed to between the ticks of periods 1 and 2, is named in done 2 as
    counted from period 4: its first picture, arriving early, waits for the tick of period 4,
    and that tick waits for it. Destroyed, it is named no more."""
    with joined(ros_context) as fake:
        simulator = next(node for node in fake.executor.get_nodes()
                         if node.get_name() == "fake_simulator")
        camera = simulator.create_publisher(String, CAMERA, RELIABLE)
        announce_with_camera(fake, 1, 0)
        fake.spin_until(lambda: 1 in fake.seen_at_done, "done 1")
        reader = fake.client.node.create_subscription(
            String, CAMERA, lambda m: fake.seen.append(m.data), RELIABLE)
        fake.spin_until(lambda: camera.get_subscription_count() > 0, "matching")
        announce_with_camera(fake, 2, 0)
        fake.spin_until(lambda: 2 in fake.seen_at_done, "done 2")
        assert fake.readings_at_done[1] == [] and fake.readings_at_done[2] == [(CAMERA, 4)]
        camera.publish(String(data="picture of period 4"))  # early: the simulator steps ahead
        fake.spin_until(lambda: fake.client.traffic.arrivals > 0, "the picture")
        announce_with_camera(fake, 3, 0)
        fake.spin_until(lambda: 3 in fake.seen_at_done, "done 3")
        assert fake.seen_at_done[3] == []
        announce_with_camera(fake, 4, 2)  # a second picture of period 4 is still on its way
        for _ in range(20):
            fake.executor.spin_once(timeout_sec=0.02)
        assert 4 not in fake.seen_at_done and fake.client.missing() == [CAMERA]
        camera.publish(String(data="second picture of period 4"))
        fake.spin_until(lambda: 4 in fake.seen_at_done, "done 4 once both pictures are in")
        assert fake.seen_at_done[4] == ["picture of period 4", "second picture of period 4"]
        fake.client.node.destroy_subscription(reader)
        announce_with_camera(fake, 5, 2)
        fake.spin_until(lambda: 5 in fake.seen_at_done, "done 5")
        assert fake.readings_at_done[4] == [(CAMERA, 4)] and fake.readings_at_done[5] == []


def test_a_new_subscription_while_the_last_done_named_the_topic_is_said_not_to_replay(
        ros_context: Any) -> None:
    """Destroyed and made again between two ticks, the camera's subscription is named anew
    from two periods on; but the simulator still renders the next period for the last done's
    subscription, and how much of it reaches the new one is DDS's business: a stall."""
    with joined(ros_context) as fake:
        node = fake.client.node
        first = node.create_subscription(String, CAMERA, lambda _m: None, RELIABLE)
        announce_with_camera(fake, 1, 0)
        fake.spin_until(lambda: 1 in fake.seen_at_done, "done 1")
        assert fake.readings_at_done[1] == [(CAMERA, 3)] and fake.client.stalls == 0
        node.destroy_subscription(first)
        node.create_subscription(String, CAMERA, lambda _m: None, RELIABLE)
        announce_with_camera(fake, 2, 0)
        fake.spin_until(lambda: 2 in fake.seen_at_done, "done 2")
        assert fake.readings_at_done[2] == [(CAMERA, 4)] and fake.client.stalls == 1
