"""Publishing on the simulator's node: the QoS it uses, sim-time stamps, and one guarded send.

Design intent: every message the simulator sends goes through :meth:`Publishing.send`, so that
lockstep counts it (:class:`~servicesim_sim.lockstep.server.LockstepServer`) and a write DDS
refuses costs that message only, never the simulator.
"""

from __future__ import annotations

import copy
from typing import Any

from builtin_interfaces.msg import Duration, Time
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from servicesim_sim.lockstep.server import LockstepServer

RCLError = rclpy_implementation.RCLError
#: No default QoS-event handlers: each is a waitable the executor adds to every wait set, and
#: the loop waits (with timeout 0) once per I/O period, hundreds of times a wall second.
#: With them the idle wait costs about 4x as much. Mismatched QoS still shows in
#: ``ros2 topic info --verbose``.
NO_PUBLISHER_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_SUBSCRIPTION_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Requests a service (or the action's goal, cancel and result services) holds until the loop
#: takes them: a burst is held whole instead of cut to ROS's default ten (about 2 MB for 5000
#: waiting room_info requests). Not KEEP_ALL: requests and replies share one profile, and a
#: KEEP_ALL reply writer whose client stopped acknowledging (a frozen process) blocks each
#: write ~100 ms once its history is full, then fails; that starved every other client of the
#: service. A KEEP_LAST writer drops the frozen client's oldest replies instead.
REQUEST_DEPTH = 10_000
EVERY_REQUEST = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=REQUEST_DEPTH,
                           reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE)
REPAIR_DEPTH = 10
"""The fewest messages a reliable writer of the node keeps. Reliable delivery repairs a lost
message only while its writer still holds it: a reader asks for what it lacks when the writer's
heartbeat comes (every 0.1 s of wall time, ``process/fastdds_profile.xml``), and a KEEP_LAST
writer drops its oldest message for each new one. Lockstep counts every message, and a client
waits for the message of period *k* before it ticks *k*, while the simulator goes on to publish
period *k* + 1 (docs/reference/simulator.md, "The pipeline"): so a writer keeps two periods'
worth (the score comes five times a period). A one-deep latched writer replaced a message a
flood of camera frames had made the client's socket drop, and the client, one message short
for good, waited in vain for it once the topic fell quiet. A latched topic keeps its meaning:
a reader one deep still gets the latest message alone."""


def repairable(qos: QoSProfile | int) -> QoSProfile | int:
    """``qos`` keeping at least :data:`REPAIR_DEPTH` messages if it is reliable and keeps the
    last ones (best effort ones, whose losses stay lost, and KEEP_ALL are left as they are)."""
    if isinstance(qos, int):
        return max(qos, REPAIR_DEPTH)
    if (qos.history == HistoryPolicy.KEEP_ALL or qos.depth >= REPAIR_DEPTH
            or qos.reliability != ReliabilityPolicy.RELIABLE):
        return qos
    deeper = copy.copy(qos)
    deeper.depth = REPAIR_DEPTH
    return deeper


def stamp_ns(seconds: float) -> int:
    return round(max(seconds, 0.0) * 1e9)


def stamp(seconds: float) -> Time:
    whole, nanoseconds = divmod(stamp_ns(seconds), 1_000_000_000)
    return Time(sec=whole, nanosec=nanoseconds)


def duration(seconds: float) -> Duration:
    whole, nanoseconds = divmod(round(max(seconds, 0.0) * 1e9), 1_000_000_000)
    return Duration(sec=whole, nanosec=nanoseconds)


class Publishing:
    """The node's publishers, made without event handlers, and the send they all go through."""

    def __init__(self, *, node: Node, lockstep: LockstepServer) -> None:
        self.node = node
        self.lockstep = lockstep
        self.dropped = 0
        """Messages DDS refused so far."""
        self._topic_names: dict[Any, str] = {}

    def publisher(self, kind: type, topic: str, qos: QoSProfile | int) -> Any:
        """A publisher on ``topic``, keeping at least :data:`REPAIR_DEPTH` messages if reliable."""
        return self.node.create_publisher(kind, topic, repairable(qos),
                                          event_callbacks=NO_PUBLISHER_EVENTS)

    def send(self, publisher: Any, message: Any) -> None:
        """Publish; a message DDS refuses is dropped with a warning, never the simulator.

        On a starved machine Fast DDS can give up on a reliable write whose reader has not
        acknowledged the writer's full history in time ("cannot publish data"); the next
        period's message carries the state on.
        """
        try:
            publisher.publish(message)
            self.lockstep.published(self._topic_of(publisher))
        except RCLError as error:
            self.dropped += 1
            if self.dropped in (1, 10, 100) or self.dropped % 1000 == 0:
                self.node.get_logger().warning(
                    f"{publisher.topic_name}: message dropped ({self.dropped} so far): "
                    f"{str(error).splitlines()[0]}")

    def _topic_of(self, publisher: Any) -> str:
        """The publisher's topic, asked of rclpy once (each ask takes its handle's lock)."""
        topic = self._topic_names.get(publisher)
        if topic is None:
            topic = self._topic_names[publisher] = publisher.topic_name
        return topic
