"""Serve a run's live ROS topics to Foxglove (``run --foxglove [[ADDR:]PORT]``).

Foxglove connects to a running robot through its WebSocket protocol; ``foxglove-sdk``'s server
speaks it. :class:`FoxgloveBridge` reads the topics a run records (``run.mcap``'s,
:data:`~bt_servicesim.records.mcap.RECORDED_TOPICS`) on the executive's node and hands each
message on to the server *as it arrived*: the CDR bytes DDS delivered, on a channel with the
same ``ros2msg`` schema the recording carries (built by
:func:`~bt_servicesim.records.mcap.complete_definition`), stamped with the node's clock, which
is sim time. Nothing is decoded: Foxglove decodes ROS 2 messages from their schema, as it does
when it opens ``run.mcap``. So what one sees live is what the recording will hold.

The server (:mod:`bt_servicesim.monitor.live_server`) is opened before anything else starts,
with a channel for every topic already (:func:`live_channels`).
Latched topics (the map, the target areas,
``/tf_static``, the task) reach a client that subscribes after they were published: the last
message of each is logged again when someone subscribes, as DDS gives a late subscriber the
publisher's kept history (clients subscribed already get it once more, which a latched topic
allows). Forwarding costs nothing while nobody is subscribed (the server drops
messages of channels without subscribers); the simulator's topics share the subscriptions the
recorder has anyway, and the run's own two (task, tree) are read back from ROS only when the run is
asked for the bridge.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import foxglove
from rclpy.node import Node

from bt_servicesim.monitor.live_server import LiveChannel, LiveServer
from bt_servicesim.records.mcap import (
    RECORDED_TOPICS,
    RecordedTopic,
    complete_definition,
    type_name,
)
from bt_servicesim.ros.shared_subscription import Reader, shared_subscription


def live_channels(topics: Iterable[RecordedTopic] = RECORDED_TOPICS) -> list[LiveChannel]:
    """The server's channels for ``topics``: each with the schema its recording carries."""
    definitions: dict[str, str] = {}
    channels = []
    for topic in topics:
        name = type_name(topic.message_type)
        if name not in definitions:
            definitions[name] = complete_definition(name)
        channels.append(LiveChannel(topic=topic.name, schema_name=name, schema=definitions[name]))
    return channels


class FoxgloveBridge:
    """Forwards ``topics`` from ``node`` to ``server`` until :meth:`close` (module docstring).

    ``server`` offers a channel for each topic (:func:`live_channels`, given when it was
    opened)."""

    def __init__(self, *, node: Node, server: LiveServer,
                 topics: Iterable[RecordedTopic] = RECORDED_TOPICS) -> None:
        self.node = node
        self.server = server
        self.counts: dict[str, int] = {}
        self._readers: list[Reader] = []
        for topic in topics:
            channel = server.channels.get(topic.name)
            if channel is None:
                raise ValueError(f"the live server offers no channel for {topic.name}")
            self.counts[topic.name] = 0
            self._readers.append(shared_subscription(
                node, topic.message_type, topic.name, self._forwards(topic, channel), topic.qos,
                raw=True))

    def _forwards(self, topic: RecordedTopic, channel: foxglove.Channel) -> Callable[[bytes], None]:
        """The callback for one topic; a latched topic's last message is replayed to clients
        that subscribe later."""
        last: list[tuple[bytes, int]] = []

        def forward(data: bytes) -> None:
            now = self.node.get_clock().now().nanoseconds
            channel.log(data, log_time=now)
            self.counts[topic.name] += 1
            if topic.latched:
                last[:] = [(data, now)]

        def replay() -> None:
            for data, logged in list(last):
                channel.log(data, log_time=logged)

        if topic.latched:
            self.server.replay_on_subscribe(channel.id(), replay)
        return forward

    def close(self) -> None:
        """Stop forwarding and stop the server; idempotent."""
        for reader in self._readers:
            reader.cancel()
        self._readers.clear()
        self.server.stop()

