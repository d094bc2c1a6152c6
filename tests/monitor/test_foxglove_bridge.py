"""The Foxglove bridge on a ROS graph: what a WebSocket client subscribed to gets, and when.

The bridge runs on a sim-time node; a second node publishes. A ``websockets`` client in a
thread of its own speaks Foxglove's protocol (advertise, subscribe, binary message frames) and
decodes the payloads with mcap-ros2-support from the advertised schemas.
"""

from __future__ import annotations

import asyncio
import json
import queue
import struct
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import websockets
from geometry_msgs.msg import TransformStamped
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from bt_servicesim.monitor.foxglove_bridge import FoxgloveBridge, live_channels
from bt_servicesim.monitor.live_server import LiveAddress, LiveServer
from bt_servicesim.records.mcap import AREA_MARKERS_TOPIC, RECORDED_TOPICS, RecordedTopic
from tests.fakes.graphs import SimTimeGraph

TOPICS = [topic for topic in RECORDED_TOPICS if topic.name in ("/tf", AREA_MARKERS_TOPIC)]
WAIT_S = 30.0  # a bound on each wait, never a duration the test relies on


class Client:
    """A Foxglove WebSocket client in its own thread: subscribes to every advertised channel,
    puts (topic, log time, decoded message) on :attr:`received`."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.received: queue.Queue[tuple[str, int, Any]] = queue.Queue()
        self.subscribed = threading.Event()
        self.closed = threading.Event()
        self._thread = threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True)
        self._thread.start()

    async def _run(self) -> None:
        decoders: dict[int, tuple[str, Any]] = {}
        try:
            async with websockets.connect(self.url, subprotocols=["foxglove.sdk.v1"]) as ws:
                async for frame in ws:
                    if isinstance(frame, bytes):
                        _, subscription, log_time = struct.unpack_from("<BIQ", frame)
                        topic, decode = decoders[subscription]
                        self.received.put((topic, log_time, decode(frame[13:])))
                        continue
                    message = json.loads(frame)
                    if message["op"] == "advertise":
                        await self._subscribe(ws, message["channels"], decoders)
        except websockets.ConnectionClosed:
            pass
        finally:
            self.closed.set()

    async def _subscribe(self, ws: Any, channels: list[dict[str, Any]],
                         decoders: dict[int, tuple[str, Any]]) -> None:
        for channel in channels:
            schema = Schema(id=channel["id"], name=channel["schemaName"], encoding="ros2msg",
                            data=channel["schema"].encode())
            decoders[channel["id"]] = (channel["topic"],
                                       DecoderFactory().decoder_for("cdr", schema))
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": channel["id"], "channelId": channel["id"]} for channel in channels]}))
        if len(decoders) == len(TOPICS):
            self.subscribed.set()

    def next(self) -> tuple[str, int, Any]:
        return self.received.get(timeout=WAIT_S)


@pytest.fixture
def bridged(sim_clock: SimTimeGraph) -> Iterator[tuple[SimTimeGraph, FoxgloveBridge]]:
    server = LiveServer(LiveAddress(port=0), channels=live_channels(TOPICS))
    bridge = FoxgloveBridge(node=sim_clock.node, server=server, topics=TOPICS)
    yield sim_clock, bridge
    bridge.close()


def publisher(graph: SimTimeGraph, topic: RecordedTopic) -> Any:
    return graph.simulator.create_publisher(topic.message_type, topic.name, topic.qos)


def test_a_client_gets_latched_messages_sent_before_it_came_and_then_live_ones(
        bridged: tuple[SimTimeGraph, FoxgloveBridge]) -> None:
    graph, bridge = bridged
    graph.jump_to(12.5)
    areas, tf = (publisher(graph, topic) for topic in TOPICS[::-1])
    graph.spin_until(lambda: areas.get_subscription_count() > 0, "the bridge to subscribe")
    areas.publish(MarkerArray(markers=[Marker(ns="area_names", id=4, text="PublicCafe")]))
    graph.spin_until(lambda: bridge.counts[AREA_MARKERS_TOPIC] == 1, "the areas to arrive")

    client = Client(bridge.server.url)
    assert client.subscribed.wait(WAIT_S)
    topic, log_time, message = client.next()  # replayed on subscription
    assert topic == AREA_MARKERS_TOPIC and log_time == 12_500_000_000
    assert [marker.text for marker in message.markers] == ["PublicCafe"]

    graph.jump_to(13.0)
    transform = TransformStamped(child_frame_id="odom")
    transform.header.frame_id, transform.transform.translation.x = "map", 2.5
    graph.spin_until(lambda: tf.get_subscription_count() > 0, "the bridge to read /tf")
    # the server files a client's subscriptions one by one on a thread of its own: the areas'
    # replay does not prove /tf's filed yet, so /tf is published until it reaches the client
    graph.spin_until(lambda: not client.received.empty(), "/tf to reach the client",
                     before=lambda: tf.publish(TFMessage(transforms=[transform])),
                     limit_s=WAIT_S)
    topic, log_time, message = client.next()
    assert topic == "/tf" and log_time == 13_000_000_000
    assert (message.transforms[0].header.frame_id, message.transforms[0].child_frame_id,
            message.transforms[0].transform.translation.x) == ("map", "odom", 2.5)

    bridge.close()
    assert client.closed.wait(WAIT_S), "closing the bridge stops the server"


def test_a_client_that_connects_before_the_bridge_is_offered_every_channel_at_once(
        sim_clock: SimTimeGraph) -> None:
    """A viewer may connect the moment the server listens (a Foxglove app left open
    reconnects): it is advertised every channel then, and subscribes to them all, before the
    bridge reads a topic; what the bridge forwards afterwards reaches it."""
    server = LiveServer(LiveAddress(port=0), channels=live_channels(TOPICS))
    client = Client(server.url)
    try:
        assert client.subscribed.wait(WAIT_S), "every channel advertised as the client came"
        bridge = FoxgloveBridge(node=sim_clock.node, server=server, topics=TOPICS)
        sim_clock.jump_to(3.0)
        tf = publisher(sim_clock, TOPICS[0])
        transform = TransformStamped(child_frame_id="odom")
        transform.header.frame_id = "map"
        sim_clock.spin_until(lambda: tf.get_subscription_count() > 0, "the bridge to read /tf")
        # the client's subscription is filed by the server's own thread, some time after the
        # client sent it: /tf is published until a message reaches the client
        sim_clock.spin_until(lambda: not client.received.empty(), "/tf to reach the client",
                             before=lambda: tf.publish(TFMessage(transforms=[transform])),
                             limit_s=WAIT_S)
        topic, log_time, _ = client.next()
        assert (topic, log_time) == ("/tf", 3_000_000_000) and bridge.counts["/tf"] >= 1
    finally:
        server.stop()
    assert client.closed.wait(WAIT_S)


def test_a_bridge_asked_for_a_topic_the_server_does_not_offer_says_which(
        sim_clock: SimTimeGraph) -> None:
    server = LiveServer(LiveAddress(port=0), channels=live_channels(TOPICS[:1]))
    try:
        with pytest.raises(ValueError, match=r"offers no channel for /servicesim/markers/areas"):
            FoxgloveBridge(node=sim_clock.node, server=server, topics=TOPICS)
    finally:
        server.stop()
