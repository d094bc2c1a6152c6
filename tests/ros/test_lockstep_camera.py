"""The camera in lockstep: a subscription made after the join sees frames from a period the
client names, the same frames in every run.

The simulator runs in its own process, held at its first period for a client; a lockstep
client in the test's process joins, subscribes to the camera in the tick of period
:data:`SUBSCRIBE_AT` and destroys the subscription in the tick of :data:`UNSUBSCRIBE_AT`. Its
done messages name the camera from two periods on, so the first frame it is handed is stamped
in that period, whenever DDS matched the subscription; the simulator renders no frame after
the period the last done that named the camera governed. Two runs give the same frames.
"""

from __future__ import annotations

import subprocess
import sys
import time
from typing import Any

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from sensor_msgs.msg import Image
from servicesim_competition.msg import LockstepPeriod

from bt_servicesim.ros.lockstep import PERIOD_TOPIC, PROTOCOL_QOS, LockstepClient, offered
from bt_servicesim.ros.node import ExecutiveNode
from tests.fakes.commands import stop_child

CAMERA = "/servicebot/camera_front/image_raw"
SUBSCRIBE_AT, UNSUBSCRIBE_AT, LAST_PERIOD = 5, 12, 16
PERIOD_S = 0.1


def frames_in_lockstep(context: Any) -> tuple[dict[int, list[float]], dict[int, int]]:
    """One run: the stamps of the frames handed on before each tick, by period, and the
    camera's count in each announcement."""
    simulator = subprocess.Popen(
        [sys.executable, "-m", "servicesim_sim", "--speed", "0", "--await-lockstep", "60"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    node = ExecutiveNode("camera_client", context=context)
    node.reliable_subscriptions = True
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    announced: dict[int, int] = {}
    node.create_subscription(LockstepPeriod, PERIOD_TOPIC, lambda m: announced.setdefault(
        int(m.period), dict(zip(m.topics, m.messages, strict=False)).get(CAMERA, -1)),
        PROTOCOL_QOS)
    handed: list[float] = []
    by_period: dict[int, list[float]] = {}
    camera: list[Subscription[Any]] = []
    client = LockstepClient(node, name="camera")
    try:
        assert offered(node, executor, wait_s=60.0), "the simulator offers no lockstep"
        assert client.join(executor, wait_s=30.0)

        def tick() -> None:
            period = round(node.get_clock().now().nanoseconds / 1e9 / PERIOD_S)
            by_period[period] = list(handed)
            handed.clear()
            if period == SUBSCRIBE_AT:
                camera.append(node.create_subscription(
                    Image, CAMERA, lambda image: handed.append(
                        image.header.stamp.sec + image.header.stamp.nanosec * 1e-9),
                    QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)))
            elif period == UNSUBSCRIBE_AT:
                node.destroy_subscription(camera.pop())

        client.ticker(PERIOD_S, tick)
        deadline = time.monotonic() + 60.0
        while LAST_PERIOD not in by_period or LAST_PERIOD + 2 not in announced:
            assert time.monotonic() < deadline, f"ticked only to {max(by_period, default=0)}"
            executor.spin_once(timeout_sec=0.05)
            client.check_stalled()
        assert client.stalls == 0 and client.dropped_at is None
        client.leave()
        # period 1, announced while the simulator waited for the join, may come before this
        # reader matched the announcer; the loop above may tick a period or two beyond what it
        # waits for, as the announcements arrive: those are no part of the run's record
        return ({period: stamps for period, stamps in by_period.items() if period <= LAST_PERIOD},
                {period: count for period, count in announced.items()
                 if 1 < period <= LAST_PERIOD + 2})
    finally:
        executor.shutdown()
        node.destroy_node()
        stop_child(simulator)


@pytest.mark.long
def test_a_camera_subscribed_in_a_tick_shows_frames_from_the_period_the_client_named(
        ros_context: Any) -> None:
    first = SUBSCRIBE_AT + 2
    runs = [frames_in_lockstep(ros_context) for _ in range(2)]
    by_period, announced = runs[0]
    assert runs[1] == runs[0], "two runs saw different frames"
    assert all(not by_period.get(period) for period in range(1, first))
    # a frame falls due every 1/24 sim s: two or three a period, stamped within it
    for period in range(first, UNSUBSCRIBE_AT + 1):
        stamps = by_period[period]
        assert 2 <= len(stamps) <= 3, (period, stamps)
        assert all((period - 1) * PERIOD_S < stamp <= period * PERIOD_S + 1e-9
                   for stamp in stamps), (period, stamps)
        assert len(stamps) == announced[period] - announced[period - 1]
    # done 12 no longer names the camera: period 13 (on done 11) is the last one rendered
    assert announced[first - 1] == 0 and announced[first] > 0
    assert announced[UNSUBSCRIBE_AT + 1] > announced[UNSUBSCRIBE_AT]
    assert announced[UNSUBSCRIBE_AT + 2] == announced[UNSUBSCRIBE_AT + 1] == announced[
        LAST_PERIOD + 2]
